"""Deciding *what kind* of fault a faulty stretch of residual shows, and how large.

Chang et al. (2017, Section 2.3, Eq. 11-13) read the type off the residual's pattern:
a constant offset (additive, ``y_f = y + D``), an oscillation whose size follows the
signal (multiplicative, ``y_f = a y``), or a linear slope (drift, ``y_f = y + b (t - t_f)``).
Here the pattern is tested rather than eyeballed: over the faulty stretch the fault
signal ``f = measured - estimated`` is regressed on each candidate shape,

* additive:       ``f = D``
* multiplicative: ``f = (a - 1) * y_ref`` (``y_ref``: the fault-free estimate; gain 0 = dead)
* drift:          ``f = c + b * tau`` (``tau``: seconds since onset; onset refined to ``-c/b``,
  which must lie between the stretch's length before the detected onset and the onset
  itself: a line meeting zero outside is refitted through the nearer end, ``b (tau - s)``)

and the shapes are compared by BIC with the healthy residual variance as the noise level
(inflated by the residual's correlation time, so coloured residuals are not over-counted).
A gain scales the reading's noise with it (``y_f = a (y_ref + e)``: the fault signal is
``(a - 1) y_ref + a e``), so the gain's fit has the noise level ``a^2`` times the healthy
one (:func:`_scaled_gain`): on a sensor whose reading sits on a large level that barely
varies, where ``(a - 1) y_ref`` is all but constant, that is what tells a gain from an
offset. Every shape may also have a noise level of its own, one parameter more
(:func:`_free_noise`), so a stretch noisier than health is not the gain's by default.
The posterior weights of the three shapes give the classification's confidence. When even
the best shape leaves most of the fault's energy above the noise unexplained (the noise
its own model implies: a gain's scaled, :func:`_explained_floor`), the fault is ``other``
(erratic, stuck, noise burst).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field

import numpy as np
import numpy.typing as npt

from analyzer.diagnosis.spread import (
    Spread,
    drift_spread,
    gain_spread,
    offset_spread,
)
from analyzer.diagnosis.streamed import LaggedSums, Series, finite_blocks, series_moments
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

MIN_GAIN = 0.1
"""Below this |gain| a multiplicative fault is treated as a dead sensor: dividing by the gain
would amplify noise more than tenfold, so the reading is not inverted."""

UNEXPLAINED_LIMIT = 0.5
"""``other`` when the best shape explains less than this share of the fault energy above
the healthy noise floor (a stated, documented rule, not a fitted constant)."""

OFF_NOISE = 2.0
"""A reading off a gain's ``a y`` by more than this many healthy residual standard
deviations is off it beyond the noise (about the two-sided 95 % point of Gaussian
noise): :func:`_erratic_reading` counts such samples."""


@dataclass(frozen=True, slots=True)
class Classification:
    type: FaultType
    magnitude: dict[str, float]
    confidence: float
    onset_shift_s: float = 0.0
    """Correction to the onset (drift: back-extrapolated slope), seconds, <= 0."""
    weights: dict[str, float] = field(default_factory=dict)
    explained: float = 0.0
    params: dict[str, float] = field(default_factory=dict)
    """Fitted shape parameters: ``offset`` (additive), ``gain`` (multiplicative),
    ``intercept`` and ``rate_per_s`` (drift, time from the detected onset)."""
    noise_scale: float = 1.0
    """The residual's spread about the shape over the healthy one, as the chosen fit has it:
    1 (the healthy level), the gain's magnitude (a gain scales the noise) or a level of
    the fit's own."""
    spread: Spread | None = None
    """The size's standard error and a drift's onset's, from the same fit and samples
    (:mod:`analyzer.diagnosis.spread`); None for ``other`` faults."""

    @property
    def weighed(self) -> bool:
        """Whether any fault shape was weighed: not over fewer than three finite residual
        samples (an alarm over a gap, or over the filters' warm-up after one), where the
        residual says nothing of a sensor's fault."""
        return bool(self.weights) or self.confidence > 0

    def fault_signal(self, tau_s: FloatArray, reference: FloatArray | None) -> FloatArray | None:
        """The fitted fault shape at ``tau_s`` seconds after the detected onset (channel
        units), or None for ``other`` faults (no shape to extend)."""
        tau = np.asarray(tau_s, dtype=np.float64)
        if self.type is FaultType.ADDITIVE:
            return np.full(tau.shape, self.params["offset"])
        if self.type is FaultType.DRIFT:
            return self.params["intercept"] + self.params["rate_per_s"] * tau
        if self.type is FaultType.MULTIPLICATIVE and reference is not None:
            return (self.params["gain"] - 1.0) * np.asarray(reference, dtype=np.float64)
        return None

    @property
    def reading_gain(self) -> float:
        """What the fault multiplies the sensor's reading by: a multiplicative fault's
        gain ``a`` (not near 0: a dead sensor cannot be inverted), 1 for the others.

        With the reference the fault-free estimate ``y_ref`` and the healthy residual
        ``e``, a gain fault's residual is ``a (y_ref + e) - y_ref = (a - 1) y_ref + a e``:
        the noise is scaled too. The residual of the corrected reading ``y / a`` is
        ``(r - fault_signal) / reading_gain = e``; subtracting the shape alone leaves
        ``a e``, whose variance a long alarm window sees as a fault of its own
        (:func:`~analyzer.diagnosis.events.diagnose_interval`)."""
        if self.type is FaultType.MULTIPLICATIVE:
            gain = float(self.params.get("gain", 1.0))
            if abs(gain) >= MIN_GAIN:
                return gain
        return 1.0


CORRELATION_LAGS = 200
"""Lags of the autocorrelation summed into a correlation time (a few seconds at 100 Hz:
more than a healthy residual's correlation lasts)."""


def correlation_time(r: Series, max_lag: int = CORRELATION_LAGS) -> float:
    """Integrated autocorrelation time (samples) of a healthy residual, >= 1: how many
    samples carry one sample's worth of independent information. ``r``: one array, or
    arrays read one after the other as one series (NaNs ignored); taken a block at a
    time (:mod:`analyzer.diagnosis.streamed`)."""
    first = series_moments(r)
    if first.n < 8:
        return 1.0
    lags = LaggedSums(max_lag)
    for x in finite_blocks(r):
        lags.add(x - first.mean)
    return integrated_time(lags.values())


def integrated_time(lagged: FloatArray) -> float:
    """:func:`correlation_time` from the lagged products of the centred series
    (:class:`~analyzer.diagnosis.streamed.LaggedSums`)."""
    if not lagged[0] > 0.0:  # a constant series: no correlation to speak of
        return 1.0
    acf = lagged / lagged[0]
    # sum until the autocorrelation first drops below zero (Geyer-style truncation)
    neg = np.flatnonzero(acf[1:] <= 0.0)
    stop = int(neg[0]) + 1 if neg.size else acf.shape[0]
    return float(max(1.0, 1.0 + 2.0 * np.sum(acf[1:stop])))


def _scaled_gain(
    n: int, energy: float, cross: float, den: float, noise: float
) -> tuple[float, float] | None:
    """The gain ``a`` of the multiplicative shape by maximum likelihood, and what its fit
    adds to ``-2 log L`` (times the noise ``s2``), or None when the reading is all zero.

    A gain multiplies the reading, noise included: with the fault-free estimate ``y`` and
    the healthy residual ``e`` (variance ``s2``), the fault signal is ``f = (a - 1) y +
    a e`` (Eq. 12 with ``y_f = a (y + e)``), so its noise is ``a e``, of variance ``a^2
    s2``, not ``s2``. A fit of the shape alone with the healthy noise level sees only the
    first term. Where ``y`` barely varies about a large level (a temperature, a pump's
    current), ``(a - 1) y`` is then a constant, as an offset is: the two fit alike, and a
    gain of 1.5 on a pump's 89-degree temperature (sweep_real_background.py) was read as
    an offset of 44.6. The scaled noise tells them apart: an offset leaves the noise as
    it was, a gain of 1.5 multiplies its spread by 1.5.

    With the reading ``z = f + y`` and ``u = 1 / a``, the model is ``u z - y = e``:
    ``-2 log L = -2 n log|u| + sum (u z - y)^2 / s2`` (constants apart), stationary where
    ``u^2 Szz - u Szy - n s2 = 0``; of its two roots (one of each sign) the one of lower
    ``-2 log L`` is the estimate. All from the sums the other fits take (``energy = Sff``,
    ``cross = Sfy``, ``den = Syy``), so the stretch is not read again. The returned
    ``-2 log L`` term is on the scale of a residual sum of squares (times ``s2``),
    ``n s2 log a^2 + sum (f - (a - 1) y)^2 / a^2``, against the other shapes' sums of
    squares: the same ``n log(2 pi s2)`` left out of each."""
    szz = energy + 2.0 * cross + den
    szy = cross + den
    if not szz > 0.0 or not noise > 0.0:
        return None
    with np.errstate(over="ignore", invalid="ignore"):
        root = float(np.sqrt(szy * szy + 4.0 * n * noise * szz))
    if not np.isfinite(root) or not np.isfinite(szz):
        # readings near 1e90 (values beyond 1e30 are gaps, but classify takes any) overflow the
        # squared sums: no scaled fit (it divided by a gain of 0 and crashed the run)
        return None
    best: tuple[float, float] | None = None
    for u in ((szy + root) / (2.0 * szz), (szy - root) / (2.0 * szz)):
        if u == 0.0 or not np.isfinite(u) or not 0.0 < 1.0 / (u * u) < np.inf:
            continue
        a = 1.0 / u
        shape = max(0.0, energy - 2.0 * (a - 1.0) * cross + (a - 1.0) ** 2 * den)
        lack = n * noise * float(np.log(a * a)) + shape / (a * a)
        if best is None or lack < best[1]:
            best = (a, lack)
    return best


def _free_noise(rss: float, k: int, floor: float) -> list[tuple[float, int, float, float]]:
    """A shape's fit with a noise level of its own, ``lambda^2 s2`` (``lambda > 1`` free, one
    parameter more) when its residual is above the healthy floor ``n s2``: what it adds
    to ``-2 log L`` (times ``s2``), ``n s2 (log lambda^2 + 1)`` with ``lambda^2 = rss / (n
    s2)``, its parameter count, ``lambda`` and a gain of 1 (the caller's for a gain);
    none when the residual is at the floor.

    Without it a shape that leaves the noise larger than in health pays for the excess in
    full, and a gain, whose model scales the noise (:func:`_scaled_gain`), pays only its
    logarithm: the gain fit took in any fault whose stretch is noisier than health (a
    drift of 10 units fitted a gain of 6.9). With it each shape may explain a noisier
    stretch alike, and a gain still wins where one parameter explains both the level and
    the spread."""
    if not floor > 0.0 or rss <= floor:
        return []
    lam2 = rss / floor
    return [(floor * (float(np.log(lam2)) + 1.0), k + 1, float(np.sqrt(lam2)), 1.0)]


def _explained_floor(kind: FaultType, gain: float, floor: float, evident: bool = True) -> float:
    """The residual energy a fault of ``kind`` leaves about its fitted shape by its own
    model, against which the shape's explained share is measured: the healthy ``floor``
    (``n s2``), or for a gain ``a`` above 1, ``a^2`` times it.

    A gain multiplies the reading's noise with it (:func:`_scaled_gain`): its fault
    signal is ``(a - 1) y + a e``, of energy ``(a - 1)^2 Syy + a^2 n s2``, and its shape
    ``(a - 1) y`` leaves ``a^2 n s2``. Measured against the healthy floor, the part
    ``(a^2 - 1) n s2`` above it, the gain's own doing, counted as unexplained: the share
    fell below :data:`UNEXPLAINED_LIMIT` wherever ``(a - 1)^2 Syy < (a^2 - 1) n s2``
    (for a gain of 1.5, a fault-free estimate whose spread is under ``sqrt(5)`` times
    the residual's), and the gain was ``other``. A 1.5 gain on the ground-floor sensor of
    ``sweep_two_faults.py`` (seed 6) was ``other`` to all three detectors, explained
    0.23-0.49, its weights all the gain's. A gain below 1 takes noise away, which the
    healthy floor already credits (its shape leaves less than the floor), so its floor
    stays the healthy one, as does a dead sensor's (below :data:`MIN_GAIN`).

    ``evident``: whether the fault signal follows the reference as that gain has it
    (:func:`_slope_evident`); only then is the noise the gain's. Where the reference is
    quiet, the scaled fit's gain comes from the noise alone: a noise burst of 3 times
    health on a reference near zero fitted a gain of 3.0 (or -3.0), and the credit
    made it explained to 1.0, a gain instead of ``other``. Without that evidence the
    floor stays the healthy one."""
    if evident and kind is FaultType.MULTIPLICATIVE and abs(gain) > 1.0:
        return floor * gain * gain
    return floor


def _erratic_reading(
    n: int, off: int, energy: float, cross: float, den: float, rss: float, floor: float
) -> float | None:
    """The share of the reading's energy above the healthy noise that the least-squares
    gain explains, when the fault is an erratic reading rather than a gain below 1; None
    when the gain stands. ``n`` samples, ``off`` of them where the reading is off the
    gain's ``a y`` by more than :data:`OFF_NOISE` healthy standard deviations; ``rss``
    what the gain leaves, ``sum (z - a y)^2``; ``floor`` the healthy ``n s2``.

    A gain below 1 takes the signal away: its shape ``(a - 1) y`` is mostly ``-y``
    whatever the reading does, so the share of the fault signal it explains (the
    classifier's ``explained``) counts the lost signal, which a dead sensor and one
    giving full-size random data uncorrelated with its signal both lose: Li et al.'s
    sensor 1 (random data at the signal's size) was a gain of -0.09 to 0.13 in 20 of 20
    failures, explained 0.54-0.66, "nearly dead". The reading ``z = f + y`` tells them
    apart: by the gain's model it is ``a (y + e)``, so what ``a y`` leaves is the
    reading's noise, within :data:`OFF_NOISE` sd at all but a few samples. The fault is
    ``other`` (erratic) when ``a y`` explains less than :data:`UNEXPLAINED_LIMIT` of the
    reading's energy above the noise (``(Szz - rss) / (Szz - n s2)``) and the reading is
    off it beyond the noise at more than that share of the samples (the reading is
    erratic throughout, not at the stretch's edges only: a windowed residual's first and
    last ``p`` samples mix the healthy readings in, and a dead sensor's reading there is
    off a gain near 0 as much as an erratic one's; Li et al.'s sensor 2, dead, left 3-14
    times the floor there, off at 5-15 % of its samples). A gain that shrinks the
    reading, with noise of its own left, stays a gain."""
    szz = energy + 2.0 * cross + den  # the reading's energy (z = f + y)
    above = szz - floor
    if not above > 0.0 or not n > 0 or off <= UNEXPLAINED_LIMIT * n:
        return None
    share = float(np.clip((szz - rss) / above, 0.0, 1.0))
    return share if share < UNEXPLAINED_LIMIT else None


def _other(
    d: float,
    energy: float,
    n: int,
    explained: float,
    weights: dict[str, float],
    params: dict[str, float],
) -> Classification:
    """An ``other`` fault (no shape explains it): its mean ``d`` and RMS as its size, the
    surer the less of it the shapes explain (``1 - explained``)."""
    return Classification(
        FaultType.OTHER,
        {"offset": d, "rms": float(np.sqrt(energy / n))},
        float(np.clip(1.0 - explained, 0.0, 1.0)),
        0.0,
        weights,
        explained,
        params,
    )


def _slope_evident(
    energy: float, rss_slope: float, n_eff: float, slope: float, gain: float
) -> bool:
    """Whether the fault signal follows the reference, with the sign of the fitted gain's
    ``gain - 1``: its least-squares ``slope`` on the reference, with a noise level of its
    own, beats no shape with a noise level of its own by BIC (one parameter more,
    ``n_eff log(energy / rss_slope) > log n_eff``, ``rss_slope`` what that slope leaves
    of the signal's ``energy``; ``n_eff`` the stretch's independent samples). What a
    gain's noise credit needs (:func:`_explained_floor`): a noise level above health's is
    anything's (a burst, an erratic sensor), a share that follows the reference is the
    gain's."""
    if not (energy > 0.0 and rss_slope > 0.0) or slope * (gain - 1.0) <= 0.0:
        return False
    return bool(n_eff * np.log(energy / rss_slope) > np.log(n_eff))


@dataclass(frozen=True, slots=True)
class ReferenceSlope:
    """How a channel's healthy residual follows its fault-free reference: ``r ~ mean +
    slope (y - level)`` over the healthy window.

    An estimator's residual is seldom quite orthogonal to its estimate (a leave-one-out
    prediction, a low-passed observer output): slopes of 0.005-0.04 were measured on the
    simulated building. That share of the residual is health, not fault; left in, a gain
    fits it. Where the reading sits on a level large against its variation, the gain an
    offset ``D`` implies, ``1 + D / level``, is itself of that size, and took the
    healthy slope for evidence: an offset of 2.16 on a channel at 1000 was reported as a
    gain of 1.00216 with weight 1 - 7e-12 (the same offset at level 10: additive). The
    classifier takes this share off the fault signal before fitting the shapes."""

    slope: float
    level: float


def reference_slope(residual: FloatArray, reference: FloatArray) -> ReferenceSlope | None:
    """The least-squares slope of the healthy ``residual`` on its ``reference`` (same
    samples: the healthy window), or None where the reference does not vary (no slope to
    speak of) or fewer than 8 samples are finite in both. Summed :data:`CLASSIFY_PIECE`
    samples at a time about the first piece's means (a day-long healthy window is not
    copied whole)."""
    n, total = 0, residual.shape[0]
    r0 = y0 = 0.0
    sy = sr = syy = syr = 0.0
    for a in range(0, total, CLASSIFY_PIECE):
        r = np.asarray(residual[a : a + CLASSIFY_PIECE], dtype=np.float64)
        y = np.asarray(reference[a : a + CLASSIFY_PIECE], dtype=np.float64)
        ok = np.isfinite(r) & np.isfinite(y)
        if not ok.any():
            continue
        r, y = r[ok], y[ok]
        if n == 0:
            r0, y0 = float(np.mean(r)), float(np.mean(y))
        r, y = r - r0, y - y0
        n += r.shape[0]
        sy += float(np.sum(y))
        sr += float(np.sum(r))
        syy += float(np.dot(y, y))
        syr += float(np.dot(y, r))
    if n < 8:
        return None
    my = sy / n
    vyy = syy - n * my * my
    level = y0 + my
    # a reference that varies by less than 1e-9 of its level is constant but for rounding
    # (a relative test: the same data in other units has the same slope)
    if not vyy > n * (1e-9 * level) ** 2 or not vyy > 0.0:
        return None
    return ReferenceSlope((syr - n * my * (sr / n)) / vyy, level)


CLASSIFY_PIECE = 1 << 18
"""Samples of a fault's stretch read at a time: the sums the fits need are taken a piece
at a time, so a fault that lasts for hours is never copied whole."""


def classify(
    fault: FloatArray,
    reference: FloatArray | None,
    sigma: float,
    rate_hz: float,
    tau_corr: float = 1.0,
    *,
    shift: float = 0.0,
    slope: ReferenceSlope | None = None,
) -> Classification:
    """Type, magnitude and confidence of the fault signal ``fault - shift`` over its
    stretch (less ``slope``'s healthy share of the reference where given).

    ``fault`` is ``measured - estimated`` from the onset on (channel units; ``shift``: the
    healthy residual mean, subtracted here a piece at a time), ``reference`` the
    fault-free estimate over the same samples (None: the multiplicative shape cannot be
    tested), ``sigma`` the healthy residual standard deviation and ``tau_corr`` its
    correlation time in samples. The three least-squares fits are computed from sums over
    :data:`CLASSIFY_PIECE` samples at a time (two passes: the means, then the sums about
    them), so memory does not grow with the stretch."""
    fault_arr = np.asarray(fault)
    ref_arr = None if reference is None else np.asarray(reference)
    total = fault_arr.shape[0]

    def pieces() -> Iterator[tuple[FloatArray, FloatArray | None, FloatArray]]:
        """The stretch's valid samples a piece at a time: ``f``, ``y`` and ``tau``."""
        for a in range(0, total, CLASSIFY_PIECE):
            b = min(total, a + CLASSIFY_PIECE)
            f = np.asarray(fault_arr[a:b], dtype=np.float64)
            if shift:
                f = f - shift
            y = None
            if ref_arr is not None:
                y = np.asarray(ref_arr[a:b], dtype=np.float64)
                if slope is not None and slope.slope:
                    f = f - slope.slope * (y - slope.level)
            ok = np.isfinite(f)
            if y is not None:
                ok &= np.isfinite(y)
                y = y[ok]
            tau = (np.flatnonzero(ok) + a).astype(np.float64) / rate_hz
            yield f[ok], y, tau

    # pass 1: counts and plain sums
    n, sum_f, sum_tau, energy, den, cross, last_tau = 0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
    for f, y, tau in pieces():
        if not f.shape[0]:
            continue
        n += f.shape[0]
        sum_f += float(np.add.reduce(f))
        sum_tau += float(np.add.reduce(tau))
        energy += float(np.sum(f * f))
        last_tau = float(tau[-1])
        if y is not None:
            den += float(np.dot(y, y))
            cross += float(np.dot(y, f))
    if n < 3:
        return Classification(FaultType.OTHER, {"offset": sum_f / n if n else 0.0}, 0.0)
    noise = max(sigma, 1e-12) ** 2
    n_eff = max(3.0, n / max(tau_corr, 1.0))
    scale = n_eff / n  # each squared residual counts for 1/tau_corr of a sample

    d = sum_f / n
    mean_tau = sum_tau / n
    g = cross / den if ref_arr is not None and den > 0.0 else None
    # pass 2: sums about the means, and the multiplicative fit's residual
    rss_add, s_tt, s_tf, rss_mult, off = 0.0, 0.0, 0.0, 0.0, 0
    for f, y, tau in pieces():
        fc = f - d
        tc = tau - mean_tau
        rss_add += float(np.sum(fc**2))
        s_tt += float(np.dot(tc, tc))
        s_tf += float(np.dot(tc, fc))
        if g is not None and y is not None:
            left = f - g * y  # what the least-squares gain leaves
            rss_mult += float(np.sum(left * left))
            off += int(np.count_nonzero(np.abs(left) > OFF_NOISE * sigma))

    fits: dict[FaultType, tuple[float, int, dict[str, float], float]] = {}
    # additive: f = D
    fits[FaultType.ADDITIVE] = (rss_add, 1, {"offset": d}, 0.0)
    # drift: f = c + b tau (least squares about the means; its residual sum of squares is
    # the additive fit's less what the slope explains)
    b = s_tf / s_tt if s_tt > 0.0 else 0.0
    c = d - b * mean_tau
    rss = max(0.0, rss_add - b * s_tf)
    onset_shift = 0.0
    held = False
    if b != 0.0:
        onset_shift = float(np.clip(-c / b, -last_tau, 0.0))
        if onset_shift != -c / b:
            held = True
            # The line meets zero outside the onsets a drift can have (after the detected
            # onset, or further back than the stretch is long): a drift b (tau - s) is
            # zero at its onset s, so the drift fit is the line through the nearest
            # admissible onset. (A lasting offset of 0.73 with a second fault's trace
            # at its end fitted 0.740 - 5.4e-5 tau, zero 13 800 s after its onset, and
            # outscored the offset by 73 units of BIC: 16 channels,
            # sweep_isolation.py --onset 0.4 --second 0.7, seed 3.)
            s_uf = s_tf + n * mean_tau * d - onset_shift * n * d  # sum (tau - s) f
            s_uu = s_tt + n * (mean_tau - onset_shift) ** 2  # sum (tau - s)^2
            b = s_uf / s_uu
            c = -b * onset_shift
            rss = max(0.0, energy - b * s_uf)
    fits[FaultType.DRIFT] = (rss, 2, {"rate_per_s": b}, onset_shift)
    params = {"offset": d, "intercept": c, "rate_per_s": b}
    # Each shape is fitted twice, once with the healthy noise level (a gain's scaled by
    # the gain: _scaled_gain) and once with a noise level of its own (one parameter
    # more, :func:`_free_noise`); the better BIC of the two stands for the shape.
    # "lack": what the fit adds to -2 log L, times the noise (a residual sum of squares
    # for the healthy level).
    floor_n = n * noise
    # (lack, parameters, noise scale, gain) of each variant of each shape
    variants: dict[FaultType, list[tuple[float, int, float, float]]] = {
        t: [(rss_t, k, 1.0, 1.0), *_free_noise(rss_t, k, floor_n)]
        for t, (rss_t, k, _, _) in fits.items()
    }
    # multiplicative: f = (a - 1) y
    if g is not None:
        gain = 1.0 + g
        scaled = _scaled_gain(n, energy, cross, den, noise) if abs(gain) >= MIN_GAIN else None
        # the least-squares gain's fit with a noise level of its own
        free = [(lack, k, lam, gain) for lack, k, lam, _ in _free_noise(rss_mult, 1, floor_n)]
        if scaled is None:  # a dead sensor: the reading no longer carries the noise to scale
            variants[FaultType.MULTIPLICATIVE] = [(rss_mult, 1, 1.0, gain), *free]
        else:
            a, lack_tied = scaled
            variants[FaultType.MULTIPLICATIVE] = [(lack_tied, 1, abs(a), a), *free]

    def score(v: tuple[float, int, float, float]) -> float:
        return v[0] * scale / noise + v[1] * np.log(n_eff)

    chosen = {t: min(vs, key=score) for t, vs in variants.items()}
    bic = {t: score(v) for t, v in chosen.items()}
    if g is not None:
        gain = chosen[FaultType.MULTIPLICATIVE][3]
        rss_g = max(0.0, energy - 2.0 * (gain - 1.0) * cross + (gain - 1.0) ** 2 * den)
        fits[FaultType.MULTIPLICATIVE] = (rss_g, 1, {"gain": gain}, 0.0)
        params["gain"] = gain
    best = min(bic, key=lambda t: bic[t])
    lo = min(bic.values())
    w = {t: float(np.exp(-0.5 * (v - lo))) for t, v in bic.items()}
    tot = sum(w.values())
    weights = {t.value: v / tot for t, v in w.items()}

    floor = n * noise
    rss_best = fits[best][0]
    excess = energy - floor
    # what the best shape leaves beyond the noise its own model implies: a gain's is its
    # reading's noise times the gain, so the energy above the healthy floor is partly its
    # doing (:func:`_explained_floor`)
    gain = params.get("gain", 1.0)
    evident = g is not None and _slope_evident(energy, rss_mult, n_eff, g, gain)
    if best is FaultType.MULTIPLICATIVE and floor > 0.0:
        # the credit only where the gain's own noise is most of what its shape leaves
        # over health (a^2 - 1 >= lambda^2 - a^2, lambda^2 = rss / floor: the noise left,
        # a free-noise fit's own lambda). Without this a gain of 1.042 whose free noise
        # was 1.121 times health's, on a healthy sensor beside a gain of 0.75 on s0
        # (seed 6), explained 0.538 with the credit (0.31 without), and a scaled gain of
        # 1.030 over 7 s of a healthy sensor whose shape left 1.157 times the floor
        # (sweep_eov rise2, 4 channels, seed 4) explained 0.620 (0.387): false gains
        lam2 = rss_best / floor
        evident = evident and gain * gain - 1.0 >= lam2 - gain * gain
    own = _explained_floor(best, gain, floor, evident)
    erratic = None
    if best is FaultType.MULTIPLICATIVE and g is not None and abs(gain) < 1.0:
        erratic = _erratic_reading(n, off, energy, cross, den, rss_mult, floor)
    if erratic is not None:
        # a reading that a gain below 1 explains at few of its samples: erratic, not a
        # gain (:func:`_erratic_reading`); its share of the reading is the explained one
        return _other(d, energy, n, erratic, weights, {**params, "reading_explained": erratic})
    explained = float((energy - rss_best + own - floor) / excess) if excess > 0 else 0.0
    # (a share: a shape that leaves less than its own model's noise, a gain's credited
    # a^2 beside a fit whose noise is less, explained 1.04-2.04 of the energy; every rule
    # that reads it compares it with a limit below 1)
    explained = min(explained, 1.0)
    if explained < UNEXPLAINED_LIMIT:
        # the more of the fault energy the shapes leave unexplained, the surer "other" is
        return _other(d, energy, n, explained, weights, params)
    _, _, mag, moved = fits[best]
    if best is FaultType.ADDITIVE:
        spread = offset_spread(pieces, n, d, tau_corr, rate_hz)
    elif best is FaultType.DRIFT:
        held_at = onset_shift if held else None
        spread = drift_spread(pieces, n, (d, c, b), mean_tau, tau_corr, held_at, rate_hz)
    else:  # the gain: the scaled fit's where that variant was chosen (one parameter)
        ml = g is not None and abs(1.0 + g) >= MIN_GAIN and chosen[best][1] == 1
        ml = ml and _scaled_gain(n, energy, cross, den, noise) is not None
        sums = (energy, cross, den)
        spread = gain_spread(pieces, n, params["gain"], sums, noise, tau_corr, ml, rate_hz)
    return Classification(
        best, mag, weights[best.value], moved, weights, explained, params, chosen[best][2], spread
    )

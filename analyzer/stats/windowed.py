"""All innovation tests over sliding windows of a long standardized residual, vectorized.

A residual of 1e7 samples cut into windows of 1e3 would take 1e4 calls of each scalar
test; here every statistic of every window comes out of whole-array operations, in
batches of windows so memory stays bounded (no Python loop per window or per sample):

* mean, variance and the lag products of the autocorrelation come from cumulative sums
  (prefix sums ``P``, window sum ``P[s + W] - P[s]``), so their cost does not grow with
  the overlap of the windows. For window [s, s + W) with shifted samples
  ``x_t = eta_t - c`` (``c`` the batch mean, which keeps the prefix sums small) and
  ``m = sum x_t / W``:

      c_0 = sum x_t^2 - W m^2
      c_k = sum_{t=s+k}^{s+W-1} x_t x_{t-k} - m (sum_{t=s+k}^{s+W-1} x_t
            + sum_{t=s}^{s+W-1-k} x_t) + (W - k) m^2,      r_k = c_k / c_0,

  which is algebraically the autocorrelation of :mod:`analyzer.stats.whiteness`;
* Shewhart outlier counts and constant-window flags are integer prefix sums (exact);
* Anderson-Darling and Cramer-von Mises sort a strided (windows, W) view along axis 1
  and apply the same kernels as the scalar tests (:mod:`analyzer.stats.normality`).

That is the numpy path, kept for when numba is missing. With numba (a dependency) every
statistic but the sort comes from the compiled kernel of
:mod:`analyzer.stats._windowed_kernel` instead: one pass per window by the scalar
definitions (autocovariances about the window mean, which are also more accurate than
prefix-sum differences), about 4x faster and free of the GIL, so threads testing
different residuals run in parallel. The two paths agree to 1e-9 (autocorrelations to
1e-10 absolute) and are tested against each other.

Each per-window statistic equals the scalar test on that window to ~1e-12 (tested to
1e-9). A window holding a NaN or inf sample is not tested: ``valid`` is False there, its
statistics are NaN and it never rejects. Windows start at 0, ``step``, ``2 step``, ...;
a trailing partial window is dropped. Seed 003 (IST Advanced Control Systems
2012/2013), "LDS - Sensor fault detection via hypothesis testing", for the tests.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np
import numpy.typing as npt
from numpy.lib.stride_tricks import sliding_window_view

from analyzer.errors import DetectorError
from analyzer.paging import release
from analyzer.stats._checks import (
    ALPHA,
    NORMALITY_MIN_N,
    Z_975,
    BoolArray,
    FloatArray,
    IntArray,
    as_float_array,
    binom_sf,
    check_case,
    check_int,
    check_positive,
    chi2_cdf,
    chi2_ppf,
    chi2_sf,
    frozen,
    norm_sf,
)
from analyzer.stats._checks import standardize as standardized_values
from analyzer.stats._windowed_kernel import window_kernel
from analyzer.stats.normality import (
    AD_CRITICAL,
    CVM_CRITICAL,
    anderson_darling_sorted,
    cramer_von_mises_sorted,
    modify_anderson_darling,
    modify_cramer_von_mises,
    standardize_sorted,
)
from analyzer.stats.outliers import expected_fraction
from analyzer.stats.whiten import whiten
from analyzer.stats.whiteness import band, default_lags, ljung_box

DEFAULT_BATCH_VALUES = 1 << 16
"""Samples handled per batch of windows (512 KiB per float64 block); peak memory is a
small multiple of this, whatever the residual's length."""


@dataclass(frozen=True, slots=True)
class WindowStats:
    """One test over all windows: per-window ``statistic``, ``reject`` and ``pvalue``
    (``None`` for the table-based normality tests), and the window-independent 5 %
    ``critical`` value (``critical_low`` for the two-sided covariance test)."""

    statistic: FloatArray
    critical: float
    reject: BoolArray
    pvalue: FloatArray | None
    critical_low: float | None = None


@dataclass(frozen=True, slots=True)
class WindowedTests:
    """Per-window results of :func:`windowed_tests`; window ``i`` covers samples
    ``[start[i], start[i] + window)``.

    Besides one :class:`WindowStats` per test: ``means`` (window means), ``outliers``
    (Shewhart counts), ``band_fraction`` (share of lags whose |r_k| > 1.96/sqrt(W)) and,
    when asked for, ``acf`` (windows, lags). ``covariance.statistic / window`` is the
    variance ratio (1 under the null).
    """

    TESTS: ClassVar[tuple[str, ...]] = (
        "shewhart",
        "anderson_darling",
        "cramer_von_mises",
        "whiteness",
        "mean",
        "covariance",
    )

    start: IntArray
    window: int
    step: int
    lags: int
    k: float
    case: int
    valid: BoolArray
    shewhart: WindowStats
    anderson_darling: WindowStats
    cramer_von_mises: WindowStats
    whiteness: WindowStats
    mean: WindowStats
    covariance: WindowStats
    means: FloatArray
    outliers: IntArray
    band_fraction: FloatArray
    acf: FloatArray | None

    @property
    def n_windows(self) -> int:
        return int(self.start.shape[0])

    def tests(self) -> dict[str, WindowStats]:
        """``{test name: WindowStats}`` in the order of :attr:`TESTS`."""
        return {name: getattr(self, name) for name in self.TESTS}


def windowed_tests(
    z: Any,
    window: int,
    step: int | None = None,
    *,
    lags: int | None = None,
    k: float = 3.0,
    case: int = 1,
    keep_acf: bool = False,
    batch_values: int = DEFAULT_BATCH_VALUES,
    standardize: tuple[float, float] | None = None,
    whitening: tuple[Sequence[float], float] | None = None,
) -> WindowedTests:
    """Run every innovation test on each window of a 1-D standardized residual ``z``.

    ``window`` samples per window (at least ``max(8, lags + 1)``), a new window every
    ``step`` samples (default ``window``: non-overlapping). ``lags`` (None:
    :func:`~analyzer.stats.whiteness.default_lags` of ``window``), ``k`` and ``case``
    are those of :func:`~analyzer.stats.whiteness.whiteness`,
    :func:`~analyzer.stats.outliers.shewhart` and the normality tests. ``keep_acf``
    stores the (windows, lags) autocorrelations. ``batch_values`` bounds the samples
    processed at once (memory), not the result.

    ``standardize=(mean, std)``: ``z`` is the raw residual (any float precision, memory-
    mapped or not), standardized as ``(z - mean) / std`` in float64 a batch at a time
    (the same two operations per sample as standardizing it whole, so the same bits)
    and its pages given back behind: no float64 copy of a long archive's residual.
    ``whitening=(coefficients, scale)`` (with ``standardize``): the standardized residual
    is whitened by that AR model's one-step error (:func:`analyzer.stats.whiten.whiten`)
    a batch at a time, each batch reading the samples before it the filter needs; the
    first ``p`` samples of the record, and those a gap reaches, leave their windows
    untested.
    """
    if whitening is not None and standardize is None:
        raise DetectorError("whitening is applied to a raw residual with standardize=")
    if standardize is not None:
        arr = np.asarray(z)
        if arr.dtype.kind != "f":
            arr = as_float_array(arr, "z")
    else:
        arr = as_float_array(z, "z")
    if arr.ndim != 1:
        raise DetectorError(f"expected a 1-D standardized residual for z, got shape {arr.shape}")
    if lags is None:
        lags = default_lags(check_int(window, "window", NORMALITY_MIN_N))
    lags = check_int(lags, "lags", 1)
    window = check_int(window, "window", max(NORMALITY_MIN_N, lags + 1))
    step = window if step is None else check_int(step, "step", 1)
    limit = check_positive(k, "k")
    case = check_case(case)
    batch_values = check_int(batch_values, "batch_values", 1)
    if arr.shape[0] < window:
        raise DetectorError(f"z has {arr.shape[0]} samples, fewer than one window of {window}")

    settings = _Settings(window, step, lags, limit, case)
    starts = np.arange(0, arr.shape[0] - window + 1, step, dtype=np.int64)
    out = _Outputs(starts.shape[0], lags, keep_acf)
    per_batch = max(1, min(batch_values // window, (batch_values - window) // step + 1))
    for first in range(0, starts.shape[0], per_batch):
        rows = slice(first, min(first + per_batch, starts.shape[0]))
        if standardize is None:
            _run_batch(arr, starts[rows], settings, out, rows)
            continue
        lo = int(starts[rows][0])
        a = lo if whitening is None else max(0, lo - len(whitening[0]))
        raw = arr[a : int(starts[rows][-1]) + window]
        seg = standardized_values(raw, *standardize)
        release(raw)  # no-op in memory
        if whitening is not None:
            p = len(whitening[0])
            if lo - a < p:  # the record begins inside the filter's reach
                seg = np.concatenate((np.full(p - (lo - a), np.nan), seg))
            seg = whiten(seg, whitening[0], whitening[1], p)
        _run_batch(seg, starts[rows] - lo, settings, out, rows)
    return out.finish(starts, settings)


@dataclass(frozen=True, slots=True)
class _Settings:
    window: int
    step: int
    lags: int
    k: float
    case: int


class _Outputs:
    """Per-window intermediate arrays, filled batch by batch."""

    def __init__(self, n_windows: int, lags: int, keep_acf: bool) -> None:
        self.valid = np.zeros(n_windows, dtype=np.bool_)
        self.constant = np.zeros(n_windows, dtype=np.bool_)
        self.means = np.empty(n_windows)
        self.sumsq = np.empty(n_windows)
        self.outliers = np.zeros(n_windows, dtype=np.int64)
        self.q = np.empty(n_windows)
        self.band_fraction = np.empty(n_windows)
        self.acf = np.empty((n_windows, lags)) if keep_acf else None
        self.a2 = np.empty(n_windows)
        self.w2 = np.empty(n_windows)

    def finish(self, starts: IntArray, settings: _Settings) -> WindowedTests:
        """Decisions and p-values of all windows; NaN for windows with a gap."""
        window, lags, case = settings.window, settings.lags, settings.case
        valid = self.valid
        untested = np.where(valid, 0.0, np.nan)  # added to every statistic

        p0 = expected_fraction(settings.k)
        outliers = np.where(valid, self.outliers, 0)
        shewhart_p = binom_sf(outliers - 1, window, p0) + untested
        z = np.sqrt(window) * self.means + untested
        mean_p = 2.0 * norm_sf(np.abs(z))
        sumsq = self.sumsq + untested
        cov_p = _two_sided_chi2(sumsq, window)
        q = self.q + untested
        q_p = chi2_sf(q, lags)
        degenerate = self.constant & (case == 2)  # no spread to standardize with
        a_star = np.where(degenerate, np.inf, modify_anderson_darling(self.a2, window, case))
        w_star = np.where(degenerate, np.inf, modify_cramer_von_mises(self.w2, window, case))
        a_star, w_star = a_star + untested, w_star + untested
        ad_critical, cvm_critical = AD_CRITICAL[case], CVM_CRITICAL[case]

        return WindowedTests(
            start=frozen(starts),
            window=window,
            step=settings.step,
            lags=lags,
            k=settings.k,
            case=case,
            valid=frozen(valid),
            shewhart=_stats(outliers / window + untested, p0, shewhart_p < ALPHA, shewhart_p),
            anderson_darling=_stats(a_star, ad_critical, a_star > ad_critical, None),
            cramer_von_mises=_stats(w_star, cvm_critical, w_star > cvm_critical, None),
            whiteness=_stats(q, float(chi2_ppf(1.0 - ALPHA, lags)), q_p < ALPHA, q_p),
            mean=_stats(np.abs(z), Z_975, mean_p < ALPHA, mean_p),
            covariance=_stats(
                sumsq,
                float(chi2_ppf(1.0 - ALPHA / 2.0, window)),
                cov_p < ALPHA,
                cov_p,
                float(chi2_ppf(ALPHA / 2.0, window)),
            ),
            means=frozen(self.means + untested),
            outliers=frozen(outliers),
            band_fraction=frozen(self.band_fraction + untested),
            acf=None if self.acf is None else frozen(self.acf + untested[:, np.newaxis]),
        )


def _two_sided_chi2(x: FloatArray, df: int) -> FloatArray:
    """``min(1, 2 min(cdf, sf))`` of chi^2(df) at ``x``, evaluating only the smaller tail
    where it is clear which one that is: below the 40 % point the CDF is the smaller (the
    survival function is then above 0.6), above the 60 % point the survival function; in
    between, and for NaN, both as before. Each evaluation is an incomplete gamma function
    (~0.3 us), the most expensive step after the windows themselves."""
    low, high = chi2_ppf([0.4, 0.6], df)
    below, above = x < low, x > high
    both = ~(below | above)
    tail = np.empty_like(x)
    tail[below] = chi2_cdf(x[below], df)
    tail[above] = chi2_sf(x[above], df)
    tail[both] = np.minimum(chi2_cdf(x[both], df), chi2_sf(x[both], df))
    out: FloatArray = np.minimum(1.0, 2.0 * tail)
    return out


def _stats(
    statistic: FloatArray,
    critical: float,
    reject: BoolArray,
    pvalue: FloatArray | None,
    critical_low: float | None = None,
) -> WindowStats:
    """A WindowStats with read-only arrays (NaN statistics compare False: never reject)."""
    return WindowStats(
        statistic=frozen(np.asarray(statistic, dtype=np.float64)),
        critical=critical,
        reject=frozen(np.asarray(reject, dtype=np.bool_)),
        pvalue=None if pvalue is None else frozen(np.asarray(pvalue, dtype=np.float64)),
        critical_low=critical_low,
    )


def _prefix(v: npt.NDArray[Any]) -> npt.NDArray[Any]:
    """Prefix sums with a leading 0: the sum of ``v[a:b]`` is ``P[b] - P[a]``."""
    out = np.empty(v.shape[0] + 1, dtype=np.int64 if v.dtype == np.bool_ else np.float64)
    out[0] = 0
    np.cumsum(v, out=out[1:])
    return out


def _run_batch(
    z: FloatArray, starts: IntArray, settings: _Settings, out: _Outputs, rows: slice
) -> None:
    """Fill ``out[rows]`` for the windows starting at ``starts`` (``step`` apart) from the
    samples they cover: by the compiled kernel when there is one, else here, where all
    sums are window differences of batch-local prefix sums."""
    window = settings.window
    seg = z[starts[0] : starts[-1] + window]
    lo = starts - starts[0]
    block = np.sort(sliding_window_view(seg, window)[:: settings.step], axis=1)
    if window_kernel is not None:
        acf = out.acf[rows] if out.acf is not None else np.empty((0, settings.lags))
        window_kernel(
            np.require(seg, requirements=["C", "W"]),  # one compiled signature
            lo,
            block,
            settings.lags,
            settings.k,
            settings.case,
            band(window),
            out.valid[rows],
            out.constant[rows],
            out.outliers[rows],
            out.means[rows],
            out.sumsq[rows],
            out.q[rows],
            out.band_fraction[rows],
            acf,
            out.a2[rows],
            out.w2[rows],
        )
        return
    hi = lo + window

    finite = np.isfinite(seg)
    gaps = _prefix(~finite)
    out.valid[rows] = gaps[hi] == gaps[lo]
    beyond = _prefix(finite & (np.abs(np.where(finite, seg, 0.0)) > settings.k))
    out.outliers[rows] = beyond[hi] - beyond[lo]
    changes = _prefix(seg[1:] != seg[:-1])  # changes[j] counts pairs (i, i+1), i < j
    constant = changes[hi - 1] == changes[lo]
    out.constant[rows] = constant

    shift = float(seg[finite].mean()) if finite.any() else 0.0
    x = np.where(finite, seg - shift, 0.0)
    p1 = _prefix(x)
    p2 = _prefix(x * x)
    s1 = p1[hi] - p1[lo]
    s2 = p2[hi] - p2[lo]
    m = s1 / window
    out.means[rows] = shift + m
    out.sumsq[rows] = s2 + 2.0 * shift * s1 + window * shift * shift
    c0 = np.where(constant, np.nan, s2 - window * m * m)
    acf = np.empty((starts.shape[0], settings.lags))
    for lag in range(1, settings.lags + 1):
        lagged = _prefix(x[lag:] * x[:-lag])  # lagged[j] sums x_{i+lag} x_i over i < j
        ck = (
            (lagged[hi - lag] - lagged[lo])
            - m * ((p1[hi] - p1[lo + lag]) + (p1[hi - lag] - p1[lo]))
            + (window - lag) * m * m
        )
        acf[:, lag - 1] = ck / c0
    q, _ = ljung_box(acf, window)
    out.q[rows] = q
    out.band_fraction[rows] = np.where(
        np.isfinite(q), np.mean(np.abs(acf) > band(window), axis=1), np.nan
    )
    if out.acf is not None:
        out.acf[rows] = acf

    standardized, _ = standardize_sorted(block, settings.case)
    out.a2[rows] = anderson_darling_sorted(standardized)
    out.w2[rows] = cramer_von_mises_sorted(standardized)

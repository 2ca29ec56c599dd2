"""Compiled one-pass-per-window kernel of :func:`analyzer.stats.windowed.windowed_tests`.

:func:`window_kernel` walks the windows of a batch and computes, for each window, what
the numpy path of :mod:`analyzer.stats.windowed` gets from prefix sums, by the
definitions of the scalar tests:

* validity (every sample finite), constant flag (min == max, the ``y_(1) == y_(N)`` of
  :func:`~analyzer.stats.normality.standardize_sorted`), Shewhart count ``|z| > k``,
  mean and sum of squares;
* autocovariances about the window mean, ``c_k = sum_t d_t d_{t-k}`` with
  ``d = z - mean`` (:mod:`analyzer.stats.whiteness`), ``r_k = c_k / c_0`` (NaN for a
  constant window), Ljung-Box Q and the share of lags outside the 95 % band;
* A^2 and W^2 of the sorted window, standardized as in ``standardize_sorted`` (case 1 as
  is, case 2 by the mean and the ``ddof=1`` standard deviation), with ``Phi`` and
  ``ln Phi`` as :func:`scipy.special.ndtr` and :func:`scipy.special.log_ndtr` compute
  them (:func:`normal_logs`). The sorted windows come in as a (windows, W) block sorted
  by numpy, whose SIMD sort is ~8x faster than numba's per-window quicksort (and also
  runs without the GIL).

``window_kernel`` is ``None`` when numba is not installed; the caller then uses numpy.
It is compiled with ``nogil=True``: threads running the tests of different detectors
compute their windows in parallel.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from analyzer.stats._checks import BoolArray, FloatArray, IntArray

_SQRT1_2 = math.sqrt(0.5)
_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)
_ASYMPTOTIC = 30.0
"""Below ``-_ASYMPTOTIC`` ``ln Phi`` comes from its asymptotic series (``Phi`` itself
underflows to subnormal numbers near -37.5)."""

window_kernel: Callable[..., None] | None
normal_logs: Callable[[float], tuple[float, float, float]] | None

try:
    from numba import njit
except ImportError:  # pragma: no cover - numba is a dependency; windowed.py falls back
    window_kernel = normal_logs = None
else:

    @njit(cache=True, nogil=True)
    def _normal_logs(x: float) -> tuple[float, float, float]:  # pragma: no cover - compiled
        """``(Phi(x), ln Phi(x), ln Phi(-x))`` from one ``erfc``, as scipy's ``ndtr`` and
        ``log_ndtr`` compute them: ``ln Phi(y) = log1p(-Phi(-y))`` for ``y >= 0`` and
        ``ln Phi(-a)`` directly, from its asymptotic series below ``-_ASYMPTOTIC``."""
        a = abs(x)
        p = 0.5 * math.erfc(a * _SQRT1_2)  # Phi(-a)
        body = math.log1p(-p)  # ln Phi(a)
        if a < _ASYMPTOTIC:
            tail = math.log(p)  # ln Phi(-a)
        else:  # -a^2/2 - ln a - ln sqrt(2 pi) + ln(1 - 1/a^2 + 3/a^4 - 15/a^6 + ...)
            inv = 1.0 / (a * a)
            total, term, k = 1.0, 1.0, 1
            while abs(term) > 1e-17:
                term *= -(2 * k - 1) * inv
                total += term
                k += 1
            tail = -0.5 * a * a - math.log(a) - _HALF_LOG_2PI + math.log(total)
        if x >= 0.0:
            return 1.0 - p, body, tail
        return p, tail, body

    @njit(cache=True, nogil=True)
    def _acf(
        d: FloatArray, c0: float, lags: int, band: float, r: FloatArray
    ) -> tuple[float, float]:  # pragma: no cover - compiled
        """``r[k-1] = c_k / c_0`` of the centred window ``d`` at lags 1..``lags``;
        returns Ljung-Box Q and the share of lags with ``|r_k| > band``."""
        n = d.shape[0]
        stat, outside = 0.0, 0
        for lag in range(1, lags + 1):
            s0, s1, s2, s3 = 0.0, 0.0, 0.0, 0.0  # four partial sums: no chain of additions
            t = lag
            while t + 3 < n:
                s0 += d[t] * d[t - lag]
                s1 += d[t + 1] * d[t + 1 - lag]
                s2 += d[t + 2] * d[t + 2 - lag]
                s3 += d[t + 3] * d[t + 3 - lag]
                t += 4
            while t < n:
                s0 += d[t] * d[t - lag]
                t += 1
            rk = ((s0 + s1) + (s2 + s3)) / c0
            r[lag - 1] = rk
            stat += rk * rk / (n - lag)
            if abs(rk) > band:
                outside += 1
        return n * (n + 2.0) * stat, outside / lags

    @njit(cache=True, nogil=True)
    def _ad_cvm(
        y: FloatArray, shift: float, scale: float
    ) -> tuple[float, float]:  # pragma: no cover - compiled
        """A^2 and W^2 of the sorted window ``y`` standardized as ``(y - shift) / scale``
        (:func:`~analyzer.stats.normality.anderson_darling_sorted` and
        :func:`~analyzer.stats.normality.cramer_von_mises_sorted`)."""
        n = y.shape[0]
        ad, cvm = 0.0, 0.0
        for j in range(n):
            cdf, log_cdf, log_sf = _normal_logs((y[j] - shift) / scale)
            # (2i - 1) ln Phi(y_(i)) + (2(N + 1 - i) - 1) ln Phi(-y_(i)), i = j + 1
            ad += (2 * j + 1) * log_cdf + (2 * (n - j) - 1) * log_sf
            gap = (2 * j + 1) / (2.0 * n) - cdf
            cvm += gap * gap
        return -n - ad / n, 1.0 / (12.0 * n) + cvm

    @njit(cache=True, nogil=True)
    def _window_kernel(
        z: FloatArray,
        lo: IntArray,
        block: FloatArray,
        lags: int,
        k: float,
        case: int,
        band: float,
        valid: BoolArray,
        constant: BoolArray,
        outliers: IntArray,
        means: FloatArray,
        sumsq: FloatArray,
        q: FloatArray,
        band_fraction: FloatArray,
        acf: FloatArray,
        a2: FloatArray,
        w2: FloatArray,
    ) -> None:  # pragma: no cover - compiled
        """Fill the per-window outputs of the windows ``z[lo[i] : lo[i] + W]``, whose
        sorted samples are the rows of ``block`` (windows, W).

        ``acf`` is (windows, lags) to keep the autocorrelations, or (0, lags) not to.
        Windows holding a non-finite sample get ``valid = False`` and NaN statistics;
        constant windows NaN autocorrelations and, in case 2, NaN A^2 and W^2.
        """
        n = block.shape[1]
        keep_acf = acf.shape[0] > 0
        d = np.empty(n)
        r = np.empty(lags)
        for i in range(lo.shape[0]):
            s = lo[i]
            total, squares, count = 0.0, 0.0, 0
            finite = True
            for t in range(s, s + n):
                v = z[t]
                if not math.isfinite(v):
                    finite = False
                    break
                total += v
                squares += v * v
                count += abs(v) > k
            valid[i], outliers[i] = finite, count
            if not finite:
                constant[i] = False
                means[i] = sumsq[i] = q[i] = band_fraction[i] = a2[i] = w2[i] = np.nan
                if keep_acf:
                    acf[i, :] = np.nan
                continue
            y = block[i]
            flat = y[0] == y[n - 1]
            m = total / n
            constant[i], means[i], sumsq[i] = flat, m, squares

            c0 = 0.0  # autocovariances about the window mean
            for t in range(n):
                d[t] = z[s + t] - m
                c0 += d[t] * d[t]
            if flat:
                r[:] = np.nan
                q[i] = band_fraction[i] = np.nan
            else:
                q[i], band_fraction[i] = _acf(d, c0, lags, band, r)
            if keep_acf:
                acf[i, :] = r

            if case == 1:
                a2[i], w2[i] = _ad_cvm(y, 0.0, 1.0)
            elif flat:  # no spread to standardize with: the caller reports infinity
                a2[i] = w2[i] = np.nan
            else:
                a2[i], w2[i] = _ad_cvm(y, m, math.sqrt(c0 / (n - 1)))

    window_kernel = _window_kernel
    normal_logs = _normal_logs

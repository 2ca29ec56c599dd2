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
  is, case 2 by the mean and the ``ddof=1`` standard deviation), with ``Phi`` as
  :func:`scipy.special.ndtr` computes it (one ``erfc`` per sample) and the weighted
  ``ln Phi`` sum of A^2 as the logarithm of running products (four ``log`` per window
  instead of two per sample, which were half the kernel's time; :func:`_ad_cvm`), or from
  ``ln Phi`` as :func:`scipy.special.log_ndtr` computes it (:func:`normal_logs`) for the
  samples beyond 20 sigma. The sorted windows come in as a (windows, W) block sorted
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
_PRODUCTS = 20.0
"""Below ``_PRODUCTS`` in absolute value a sample's ``Phi(y)`` and ``Phi(-y)`` enter the
running products of :func:`_ad_cvm` (both above Phi(-20) ~ 2^-294.2); beyond, its
``ln Phi`` come from :func:`_normal_logs`."""
_LOW, _LOW_UP, _LOW_SCALE = 2.0**-300, 2.0**300, 300
"""Rescaling point of the products of ``Phi``: kept in [2^-300, 1], so one factor takes
them no lower than 2^-595 and one rescaling by 2^300 back above 2^-300."""
_OUTER, _OUTER_UP, _OUTER_SCALE = 2.0**-700, 2.0**700, 700
"""Rescaling point of the products of those products: kept in [2^-700, 1], so one
factor (>= 2^-300) takes them no lower than 2^-1000, still a normal number, and one
rescaling by 2^700 back above 2^-700; the wide range makes rescaling (a mispredicted
branch) rare."""
_LN2_HI = 6.93147180369123816490e-01  # ln 2 to 32 bits (fdlibm): k ln2_hi is exact
_LN2_LO = 1.90821492927058770002e-10  # ln 2 - ln2_hi

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
        returns Ljung-Box Q and the share of lags with ``|r_k| > band``.

        Four lags at a time: each ``d[t]`` is loaded once for the four products
        ``d[t] d[t - lag]`` (five loads for four products instead of eight, the bound of
        the one-lag-at-a-time loop); the ``t < top`` terms that not all four lags have
        are added per lag first."""
        n = d.shape[0]
        stat, outside = 0.0, 0
        for first in range(1, lags + 1, 4):
            top = first + 3  # the block's largest lag: from t = top on all four have terms
            a0, a1, a2, a3 = 0.0, 0.0, 0.0, 0.0  # lags first .. first + 3
            for t in range(top, n):
                dt = d[t]
                b = t - top
                a3 += dt * d[b]
                a2 += dt * d[b + 1]
                a1 += dt * d[b + 2]
                a0 += dt * d[b + 3]
            block = (a0, a1, a2, a3)
            for j in range(4):
                lag = first + j
                if lag > lags:
                    break
                head = 0.0
                for t in range(lag, min(top, n)):
                    head += d[t] * d[t - lag]
                rk = (head + block[j]) / c0
                r[lag - 1] = rk
                stat += rk * rk / (n - lag)
                if abs(rk) > band:
                    outside += 1
        return n * (n + 2.0) * stat, outside / lags

    @njit(cache=True, nogil=True)
    def _log_scaled(x: float, bits: int) -> float:  # pragma: no cover - compiled
        """``ln(x 2^-bits)``, exactly up to the rounding of one ``log`` of a number in
        [0.5, 1) (``k ln 2`` split as in fdlibm so that ``k ln2_hi`` is exact)."""
        m, e = math.frexp(x)
        k = e - bits
        return math.log(m) + k * _LN2_HI + k * _LN2_LO

    @njit(cache=True, nogil=True)
    def _ad_cvm(
        y: FloatArray, shift: float, scale: float, cdf: FloatArray, sf: FloatArray
    ) -> tuple[float, float]:  # pragma: no cover - compiled
        """A^2 and W^2 of the sorted window ``y`` standardized as ``(y - shift) / scale``
        (:func:`~analyzer.stats.normality.anderson_darling_sorted` and
        :func:`~analyzer.stats.normality.cramer_von_mises_sorted`); ``cdf`` and ``sf`` are
        scratch arrays of the window's length.

        ``Phi(y_(i))`` and ``Phi(-y_(i))`` come from one ``erfc`` each, as in
        :func:`_normal_logs`. Instead of two logarithms per sample (most of the cost), the
        weighted log sum of A^2 is the logarithm of running products:

            sum_i (2i - 1) ln a_i = 2 sum_k ln U_k - ln U_1,  U_k = prod_{i >= k} a_i

        (``2i - 1 = 2 #{k <= i} - 1``), so ``prod_k U_k`` and ``U_1`` give it with two
        logarithms per window; ``b_i = Phi(-y_(i))``, whose weights fall with ``i``, the
        same way with prefix products. The products are kept normal numbers by exact
        powers of two, counted in ``*_bits`` (see ``_LOW`` and ``_OUTER``). A product of
        4N roundings is good to ~4N ulp *relative*, i.e. its log to ~1e-13 *absolute*,
        which beats the sum of 2N weighted logs (rounding errors of terms up to ~N in
        size); the tests compare with scipy's ``log_ndtr`` sums. Samples beyond
        ``_PRODUCTS`` sigma add their logs from :func:`_normal_logs` instead.
        """
        n = y.shape[0]
        cvm, tails = 0.0, 0.0
        for j in range(n):
            x = (y[j] - shift) / scale
            a = abs(x)
            if a < _PRODUCTS:
                p = 0.5 * math.erfc(a * _SQRT1_2)  # Phi(-a), as _normal_logs
                if x >= 0.0:
                    phi = 1.0 - p
                    cdf[j], sf[j] = phi, p
                else:
                    phi = p
                    cdf[j], sf[j] = p, 1.0 - p
            else:
                phi, log_cdf, log_sf = _normal_logs(x)
                tails += (2 * j + 1) * log_cdf + (2 * (n - j) - 1) * log_sf
                cdf[j] = sf[j] = 1.0  # ln 1 = 0 in the products
            gap = (2 * j + 1) / (2.0 * n) - phi
            cvm += gap * gap
        # suffix products of cdf (u, and the product of the u's: w), prefix products of
        # sf (v, and x); the true values are u 2^-u_bits etc.
        u, w, v, x = 1.0, 1.0, 1.0, 1.0
        u_bits, w_bits, v_bits, x_bits = 0, 0, 0, 0
        for i in range(n):
            u *= cdf[n - 1 - i]
            if u < _LOW:
                u *= _LOW_UP
                u_bits += _LOW_SCALE
            w *= u
            w_bits += u_bits
            if w < _OUTER:
                w *= _OUTER_UP
                w_bits += _OUTER_SCALE
            v *= sf[i]
            if v < _LOW:
                v *= _LOW_UP
                v_bits += _LOW_SCALE
            x *= v
            x_bits += v_bits
            if x < _OUTER:
                x *= _OUTER_UP
                x_bits += _OUTER_SCALE
        ad = (2.0 * _log_scaled(w, w_bits) - _log_scaled(u, u_bits)) + (
            2.0 * _log_scaled(x, x_bits) - _log_scaled(v, v_bits)
        )
        return -n - (ad + tails) / n, 1.0 / (12.0 * n) + cvm

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
        cdf, sf = np.empty(n), np.empty(n)
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
                a2[i], w2[i] = _ad_cvm(y, 0.0, 1.0, cdf, sf)
            elif flat:  # no spread to standardize with: the caller reports infinity
                a2[i] = w2[i] = np.nan
            else:
                a2[i], w2[i] = _ad_cvm(y, m, math.sqrt(c0 / (n - 1)), cdf, sf)

    window_kernel = _window_kernel
    normal_logs = _normal_logs

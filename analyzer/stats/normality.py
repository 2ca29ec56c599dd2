"""Normality tests of the standardized innovation: Anderson-Darling and Cramer-von Mises.

Seed 003 (IST Advanced Control Systems 2012/2013), "LDS - Sensor fault detection via
hypothesis testing: Normality Tests", slides 61/94 and following. Two cases after
Stephens (1974):

* case 1: mean 0 and variance 1 known; the standardized innovation eta is tested as is;
* case 2: both estimated from the sample (mean, standard deviation with ``ddof=1``, as
  :func:`scipy.stats.anderson` does) and the sample standardized with them. Stephens
  reports this case to have more power even when the parameters are known.

The sorted sample ``y_(1) <= ... <= y_(N)`` enters

    A^2 = -N - (1/N) sum_i (2i - 1) [ln Phi(y_(i)) + ln(1 - Phi(y_(N+1-i)))]    (slide 61)
    W^2 = 1/(12N) + sum_i ((2i - 1)/(2N) - Phi(y_(i)))^2

and the modified statistics with their 5 % points (the slides' table) are

    case 1: A^2                                 > 2.492
            (W^2 - 0.4/N + 0.6/N^2)(1 + 1/N)    > 0.461
    case 2: A^2 (1 + 4/N - 25/N^2)              > 0.787
            W^2 (1 + 0.5/N)                     > 0.126

The slides' case-2 Anderson-Darling point is Stephens' (1974) and slightly conservative:
on white noise it rejects about 3.7 % of samples at N = 500 to 2000 (measured over 4000
windows; the other three keep 4.5-5 %). ``scipy.stats.anderson`` uses the later
D'Agostino and Stephens (1986) form A^2 (1 + 0.75/N + 2.25/N^2) against 0.752.

The kernels :func:`anderson_darling_sorted` and :func:`cramer_von_mises_sorted` work on
the last axis, so :mod:`analyzer.stats.windowed` applies the very same arithmetic to a
(windows, N) block of sorted windows. The decision is the tabulated one; the p-value
beside it (:func:`normality_pvalue`) comes from the published approximations of each
case's null law:

* case 1 (the law N(0, 1) known, not fitted to the sample tested): Anderson-Darling
  from Marsaglia and Marsaglia (2004), "Evaluating the Anderson-Darling distribution"
  (the asymptotic law with their correction for N); Cramer-von Mises, Stephens'
  modified statistic (made to follow the asymptotic law at any N) against that law
  (Csorgo and Faraway 1996, eq. 1.2, as :func:`scipy.stats.cramervonmises` sums it;
  within 0.002 of its finite-N p-value at N = 500; scipy.stats itself is not imported,
  0.6-0.8 s of start-up);
* case 2 (mean and deviation fitted to the sample): D'Agostino and Stephens (1986),
  Table 4.9, on A^2 (1 + 0.75/N + 2.25/N^2) and W^2 (1 + 0.5/N) (the formulas of
  ``statsmodels.stats.diagnostic.normal_ad`` and of R's ``nortest``).

A p-value of a case-1 test is honest only as far as the law is truly known: here the
mean, deviation and whitening come from the training window, not from the stretch
tested, so case 1 is the right case, but their own estimation error is not in it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.special import gammaln, kv, log_ndtr, ndtr

from analyzer.stats._checks import (
    NORMALITY_MIN_N,
    BoolArray,
    FloatArray,
    as_series,
    check_case,
)
from analyzer.stats.results import NormalityResult

AD_CRITICAL = {1: 2.492, 2: 0.787}
"""5 % points of the (modified) Anderson-Darling statistic, by case (slides' table)."""

CVM_CRITICAL = {1: 0.461, 2: 0.126}
"""5 % points of the modified Cramer-von Mises statistic, by case (slides' table)."""


def anderson_darling_sorted(y: FloatArray) -> FloatArray:
    """A^2 of samples sorted along the last axis and already standardized (slide 61/94).

    ``ln(1 - Phi(y))`` is evaluated as ``ln Phi(-y)`` (``scipy.special.log_ndtr``), which
    stays finite far in the tails, exactly as :func:`scipy.stats.anderson` does.
    """
    n = y.shape[-1]
    weights = np.arange(1.0, 2.0 * n, 2.0)
    logs = log_ndtr(y) + log_ndtr(-y[..., ::-1])
    out: FloatArray = -n - np.sum(weights * logs, axis=-1) / n
    return out


def cramer_von_mises_sorted(y: FloatArray) -> FloatArray:
    """W^2 of samples sorted along the last axis and already standardized."""
    n = y.shape[-1]
    plotting = np.arange(1.0, 2.0 * n, 2.0) / (2.0 * n)
    out: FloatArray = 1.0 / (12.0 * n) + np.sum((plotting - ndtr(y)) ** 2, axis=-1)
    return out


def modify_anderson_darling(a2: FloatArray | float, n: int, case: int) -> FloatArray:
    """Stephens' modification: A^2 itself in case 1, ``A^2 (1 + 4/N - 25/N^2)`` in case 2."""
    a2 = np.asarray(a2, dtype=np.float64)
    if case == 1:
        return a2
    out: FloatArray = a2 * (1.0 + 4.0 / n - 25.0 / n**2)
    return out


def modify_cramer_von_mises(w2: FloatArray | float, n: int, case: int) -> FloatArray:
    """Stephens' modification: ``(W^2 - 0.4/N + 0.6/N^2)(1 + 1/N)`` in case 1,
    ``W^2 (1 + 0.5/N)`` in case 2."""
    w2 = np.asarray(w2, dtype=np.float64)
    if case == 2:
        scaled: FloatArray = w2 * (1.0 + 0.5 / n)
        return scaled
    out: FloatArray = (w2 - 0.4 / n + 0.6 / n**2) * (1.0 + 1.0 / n)
    return out


def standardize_sorted(y: FloatArray, case: int) -> tuple[FloatArray, BoolArray]:
    """Rows of sorted samples ready for the kernels, and a mask of constant rows.

    Case 1 returns ``y`` unchanged. Case 2 subtracts each row's mean and divides by its
    standard deviation (``ddof=1``); a constant row (first == last sorted value) has no
    spread to standardize with and is flagged instead (its statistic is then infinite).
    """
    constant: BoolArray = y[..., 0] == y[..., -1]
    if case == 1:
        return y, constant
    mean = np.mean(y, axis=-1, keepdims=True)
    std = np.std(y, axis=-1, ddof=1, keepdims=True)
    std = np.where(constant[..., np.newaxis], 1.0, std)
    out: FloatArray = (y - mean) / std
    return out, constant


def _marsaglia_cdf(a2: float, n: int) -> float:
    """P(A^2 <= a2) for a sample of ``n`` from a known continuous law: Marsaglia and
    Marsaglia's (2004) asymptotic ``adinf`` plus their finite-N ``errfix``."""
    z = float(a2)
    if not z > 0:
        return 0.0
    if z < 2.0:
        inner = 0.0347962 - (0.011672 - 0.00168691 * z) * z
        poly = 2.00012 + (0.247105 - (0.0649821 - inner * z) * z) * z
        x = float(np.exp(-1.2337141 / z) / np.sqrt(z) * poly)
    else:
        inner = 0.082433 - (0.008056 - 0.0003146 * z) * z
        x = float(np.exp(-np.exp(1.0776 - (2.30695 - (0.43424 - inner * z) * z) * z)))
    c = 0.01265 + 0.1757 / n
    if x > 0.8:
        poly = 1950.646 - (1116.360 - 255.7844 * x) * x
        fix = (-130.2137 + (745.2337 - (1705.091 - poly * x) * x) * x) / n
    elif x < c:
        t = x / c
        t = np.sqrt(t) * (1.0 - t) * (49.0 * t - 102.0)
        fix = float(t * (0.0037 / n**2 + 0.00078 / n + 0.00006) / n)
    else:
        t = (x - c) / (0.8 - c)
        t = -0.00022633 + (6.54034 - (14.6538 - (14.458 - (8.259 - 1.91864 * t) * t) * t) * t) * t
        fix = t * (0.04213 + 0.01365 / n) / n
    return min(1.0, max(0.0, x + fix))


def _ad_case2_pvalue(a2: float, n: int) -> float:
    """D'Agostino and Stephens (1986) p-value of A^2 with mean and deviation fitted."""
    a = a2 * (1.0 + 0.75 / n + 2.25 / n**2)
    if a < 0.2:
        p = 1.0 - np.exp(-13.436 + 101.14 * a - 223.73 * a**2)
    elif a < 0.34:
        p = 1.0 - np.exp(-8.318 + 42.796 * a - 59.938 * a**2)
    elif a < 0.6:
        p = np.exp(0.9177 - 4.279 * a - 1.38 * a**2)
    elif a < 10.0:
        p = np.exp(1.2937 - 5.709 * a + 0.0186 * a**2)
    else:
        p = 0.0
    return float(min(1.0, max(0.0, p)))


def _cvm_case2_pvalue(w2: float, n: int) -> float:
    """D'Agostino and Stephens (1986) p-value of W^2 with mean and deviation fitted."""
    w = w2 * (1.0 + 0.5 / n)
    if w < 0.0275:
        p = 1.0 - np.exp(-13.953 + 775.5 * w - 12542.61 * w**2)
    elif w < 0.051:
        p = 1.0 - np.exp(-5.903 + 179.546 * w - 1515.29 * w**2)
    elif w < 0.092:
        p = np.exp(0.886 - 31.62 * w + 10.897 * w**2)
    elif w < 1.1:
        p = np.exp(1.111 - 34.242 * w + 12.832 * w**2)
    else:
        p = 0.0
    return float(min(1.0, max(0.0, p)))


CVM_TAIL_END = 5.0
"""Where the asymptotic Cramer-von Mises law's upper tail is taken as 0: its 0.001 point
is 1.168, and past about 2000 the series below lost its precision (``1 - cdf`` rose back
to 0.01-0.23, a review); at 5 the tail is far below any p-value shown."""


def _cvm_asymptotic_cdf(w2: float) -> float:
    """P(W^2 <= w2) of the asymptotic Cramer-von Mises law (Csorgo and Faraway 1996,
    eq. 1.2; terms added until they fall under 1e-10, as scipy's ``_cdf_cvm_inf``)."""
    x = float(w2)
    if not x > 0:
        return 0.0
    if x >= CVM_TAIL_END:
        return 1.0  # (the series' terms lose their sum there: 1 - cdf climbed to 0.23)
    total, k = 0.0, 0
    while k < 100:
        y = 4 * k + 1
        q = y * y / (16.0 * x)
        u = np.exp(gammaln(k + 0.5) - gammaln(k + 1)) / (np.pi**1.5 * np.sqrt(x))
        term = float(u * np.sqrt(y) * np.exp(-q) * kv(0.25, q))
        total += term
        if abs(term) < 1e-10:
            break
        k += 1
    return min(1.0, max(0.0, total))


def normality_pvalue(test: str, case: int, raw: float, y: FloatArray) -> float | None:
    """The p-value of ``test`` (``anderson_darling`` or ``cramer_von_mises``) of the
    sorted sample ``y`` whose unmodified statistic is ``raw``, in Stephens' ``case``
    (module docstring: which approximation); None where the statistic is not finite."""
    n = y.shape[0]
    if not np.isfinite(raw):
        return None
    if test == "anderson_darling":
        return 1.0 - _marsaglia_cdf(raw, n) if case == 1 else _ad_case2_pvalue(raw, n)
    if case == 1:
        return 1.0 - _cvm_asymptotic_cdf(float(modify_cramer_von_mises(raw, n, 1)))
    return _cvm_case2_pvalue(raw, n)


def _normality(
    x: Any,
    case: int,
    test: str,
    critical: dict[int, float],
    kernel: Callable[[FloatArray], FloatArray],
    modify: Callable[[FloatArray | float, int, int], FloatArray],
) -> NormalityResult:
    case = check_case(case)
    y = np.sort(as_series(x, "x", NORMALITY_MIN_N))
    n = y.shape[0]
    z, constant = standardize_sorted(y, case)
    if case == 2 and bool(constant):
        raw = statistic = float("inf")
    else:
        raw = float(kernel(z))
        statistic = float(modify(raw, n, case))
    return NormalityResult(
        statistic=statistic,
        critical=critical[case],
        reject=statistic > critical[case],
        pvalue=normality_pvalue(test, case, raw, y),
        n=n,
        test=test,
        case=case,
        raw=raw,
    )


def anderson_darling(x: Any, case: int = 1) -> NormalityResult:
    """Anderson-Darling test of a 1-D standardized innovation ``x`` (NaN dropped).

    ``raw`` is A^2; ``statistic`` is A^2 in case 1 (known N(0, 1), 5 % point 2.492) and
    A*^2 = A^2 (1 + 4/N - 25/N^2) in case 2 (mean and std estimated, 5 % point 0.787).
    In case 2 ``raw`` equals ``scipy.stats.anderson(x, "norm").statistic``. A constant
    sample has no spread to estimate in case 2: its statistic is infinite and rejected.
    Seed 003, slide 61/94 and the two that follow.
    """
    return _normality(
        x, case, "anderson_darling", AD_CRITICAL, anderson_darling_sorted, modify_anderson_darling
    )


def cramer_von_mises(x: Any, case: int = 1) -> NormalityResult:
    """Cramer-von Mises test of a 1-D standardized innovation ``x`` (NaN dropped).

    ``raw`` is W^2 (in case 1 equal to ``scipy.stats.cramervonmises(x, "norm").statistic``);
    ``statistic`` is (W^2 - 0.4/N + 0.6/N^2)(1 + 1/N) in case 1 (5 % point 0.461) and
    W^2 (1 + 0.5/N) in case 2 (5 % point 0.126). A constant sample is rejected in case 2
    with an infinite statistic. Seed 003, "Normality Tests - Cramer-von Mises criterion".
    """
    return _normality(
        x,
        case,
        "cramer_von_mises",
        CVM_CRITICAL,
        cramer_von_mises_sorted,
        modify_cramer_von_mises,
    )

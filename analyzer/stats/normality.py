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
(windows, N) block of sorted windows. No p-value is reported: the decision is the
tabulated one.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from scipy.special import log_ndtr, ndtr

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
        pvalue=None,
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

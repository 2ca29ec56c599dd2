"""Outlier detection by limit checking: the Shewhart chart of the standardized innovation.

Seed 003 (IST Advanced Control Systems 2012/2013), slide 52/94 "LDS - Outlier Detection
via limit value checking": with the standardized innovation eta(t+1) ~ N(0, 1), the
measurement z(t+1) is an outlier whenever |eta(t+1)| > 3, which happens by chance with
probability 0.27 %. The slides' practical case found 225 outliers in 1e5 samples (0.22 %)
and called that "within the significance level"; here that judgement is a one-sided
binomial test of the outlier count against the expected fraction.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from analyzer.errors import DetectorError
from analyzer.stats._checks import (
    ALPHA,
    as_float_array,
    binom_sf,
    check_positive,
    frozen,
    norm_sf,
)
from analyzer.stats.results import ShewhartResult


def expected_fraction(k: float) -> float:
    """Chance that a N(0, 1) sample falls outside +-k: ``2 (1 - Phi(k))`` (0.27 % at k=3)."""
    return float(2.0 * norm_sf(k))


def shewhart(x: Any, k: float = 3.0) -> ShewhartResult:
    """Shewhart chart of a standardized innovation ``x`` (1-D, or (N, r) component-wise).

    ``outliers = |x| > k`` (same shape as ``x``, False at NaN). The statistic is the
    outlier fraction ``count / n`` over the ``n`` finite samples; ``critical`` is the
    fraction expected under the null, ``p0 = 2 (1 - Phi(k))``. The chart rejects when
    the count is improbably high for Binomial(n, p0):
    ``pvalue = P(Binomial(n, p0) >= count) < 0.05`` (one-sided: too few outliers is not a
    fault). Seed 003, slide 52/94.
    """
    limit = check_positive(k, "k")
    arr = as_float_array(x, "x")
    if arr.ndim not in (1, 2):
        raise DetectorError(
            f"expected a 1-D or (N, r) standardized innovation for x, got shape {arr.shape}"
        )
    if arr.size == 0:
        raise DetectorError(f"x is empty (shape {arr.shape}); expected samples")
    finite = np.isfinite(arr)
    n = int(finite.sum())
    if n == 0:
        raise DetectorError(
            f"all {arr.size} values of x are NaN or infinite; expected finite samples"
        )
    outliers = finite & (np.abs(np.where(finite, arr, 0.0)) > limit)
    count = int(outliers.sum())
    p0 = expected_fraction(limit)
    pvalue = float(binom_sf(count - 1, n, p0))
    return ShewhartResult(
        statistic=count / n,
        critical=p0,
        reject=pvalue < ALPHA,
        pvalue=pvalue,
        n=n,
        k=limit,
        count=count,
        outliers=frozen(outliers),
    )

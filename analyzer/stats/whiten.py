"""The one-step prediction error of an autoregressive model: the whitening filter the
innovation tests run after (:mod:`analyzer.diagnosis.evidence` fits it)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from analyzer.stats._checks import FloatArray


def whiten(z: FloatArray, coefficients: Sequence[float], scale: float, history: int) -> FloatArray:
    """``e[t] = (z[t] - sum_k a[k] z[t - k]) / scale`` (``a = coefficients``, lags 1..p)
    for the samples of ``z`` after its first ``history`` (the samples before the stretch
    wanted, at most p). A sample whose window ``[t - p, t]`` holds a NaN or reaches
    before ``z``'s start is NaN (the tests drop it, or leave its window untested)."""
    p = len(coefficients)
    n = z.shape[0]
    if n <= history:
        return np.zeros(0)
    kernel = np.concatenate(([1.0], -np.asarray(coefficients, dtype=np.float64)))
    bad = ~np.isfinite(z)
    gaps = bool(bad.any())
    x = np.where(bad, 0.0, z) if gaps else z
    e: FloatArray = np.convolve(x, kernel)[:n]
    e /= scale
    e[: min(p, n)] = np.nan  # the window reaches before the data
    if gaps:  # and where it holds a gap: the p samples after each
        reach = np.convolve(bad.astype(np.float64), np.ones(p + 1))[:n]
        e[reach > 0.5] = np.nan
    return e[history:]


__all__ = ["whiten"]

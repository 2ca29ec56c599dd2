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
    if z.shape[0] <= history:
        return np.zeros(0)
    kernel = np.concatenate(([1.0], -np.asarray(coefficients, dtype=np.float64)))
    bad = ~np.isfinite(z)
    x = np.where(bad, 0.0, z)
    e: FloatArray = np.convolve(x, kernel)[: x.shape[0]] / scale
    if p:
        # NaN where the window [t - p, t] holds a gap, or reaches before the data
        reach = np.convolve(np.concatenate((np.ones(p), bad)), np.ones(p + 1))[p : p + x.shape[0]]
        e[reach > 0.5] = np.nan
    else:
        e[bad] = np.nan
    return e[history:]


__all__ = ["whiten"]

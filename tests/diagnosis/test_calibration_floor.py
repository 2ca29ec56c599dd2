"""The spread of the window means that sets the mean thresholds is never below the spread
measured directly on the training residual.

``calibrate`` takes the larger of a model-based spread (Priestley 1981, Eq. 5.3.5, from
the autocorrelations inside the ``2 / sqrt(n)`` band) and the direct one. A slow wander
whose autocorrelation at every lag sits inside the band is invisible to the model, not to
the window means. Reference: the sample standard deviation (ddof 1) of every ``w``-sample
moving mean of the standardized residual, computed here with numpy."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.diagnosis import calibrate


def _direct_spread(r: np.ndarray, w: int) -> float:
    z = (r - r.mean()) / r.std(ddof=1)
    return float(np.std(np.convolve(z, np.ones(w) / w, "valid"), ddof=1))


@pytest.mark.parametrize("seed", [5, 7])
def test_window_mean_spread_is_at_least_the_direct_one(seed):
    """White noise plus a weak wander (unit noise summed over 3000 samples, times 0.12),
    40 000 training samples, windows of 50 and 400: ``cal.mean_sd`` equals the direct
    spread of the window means, which is the larger here (the model-based spread of the
    400-sample mean is 10 % and 24 % lower on these two records)."""
    rng = np.random.default_rng(seed)
    n = 40_000
    wander = np.convolve(rng.normal(size=n + 2999), np.ones(3000) / np.sqrt(3000), "valid")
    r = rng.normal(size=n) + 0.12 * wander
    cal = calibrate(r, 50, 1e-6)
    assert cal.windows == (50, 400)
    for w, sd in zip(cal.windows, cal.mean_sd, strict=True):
        direct = _direct_spread(r, w)
        assert sd >= direct * (1 - 1e-9)
        assert sd == pytest.approx(direct, rel=1e-9)

"""The classification's BIC counts a coloured residual's samples by its correlation time.

References: (1) information, not sample count: ``n`` values each repeated ``T`` times carry
what the ``n`` values carry, so with a correlation time of ``T`` samples they must weigh
the shapes as the ``n`` values do with a correlation time of 1. (2) The integrated
correlation time of AR(1) noise, ``(1 + phi) / (1 - phi)`` in closed form."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from analyzer.diagnosis.classify import classify


@pytest.mark.parametrize("seed", [1, 2])
def test_repeated_samples_weigh_as_the_samples_themselves(seed):
    """A 0.5 sd offset on 40 white-noise samples at 1 Hz (reference ``5 + noise``), and the
    same 40 values each repeated 25 times at 25 Hz with a correlation time of 25: the
    same shape weights and confidence (to 0.002: the repeated copies' times differ
    within each second, which moves the drift's fit a little), and neither is certain."""
    rng = np.random.default_rng(seed)
    n, T = 40, 25
    f = rng.normal(size=n) + 0.5
    y = 5.0 + rng.normal(size=n)
    once = classify(f, y, 1.0, 1.0, tau_corr=1.0)
    repeated = classify(np.repeat(f, T), np.repeat(y, T), 1.0, float(T), tau_corr=float(T))
    assert max(once.weights.values()) < 0.9  # 40 samples cannot tell the shapes apart
    assert repeated.weights.keys() == once.weights.keys()
    for k, w in once.weights.items():
        assert repeated.weights[k] == pytest.approx(w, abs=0.002)
    assert repeated.type is once.type
    assert repeated.confidence == pytest.approx(once.confidence, abs=0.002)


def test_coloured_noise_does_not_make_a_weak_offset_certain():
    """A 0.5 sd offset on AR(1) noise (phi = 0.97, unit variance), 2000 samples at 100 Hz,
    classified with the closed-form correlation time ``(1 + phi) / (1 - phi)`` (about 66:
    some 30 independent samples): no shape reaches a weight of 0.9. Counted as 2000
    independent samples, one shape got a weight of 1.00."""
    rng = np.random.default_rng(1)
    phi = 0.97
    e = lfilter([1.0], [1.0, -phi], rng.normal(size=2000)) * np.sqrt(1 - phi**2)
    c = classify(e + 0.5, None, 1.0, 100.0, tau_corr=(1 + phi) / (1 - phi))
    assert max(c.weights.values()) < 0.9
    assert c.confidence < 0.9

"""The whitening filter's first ``p`` outputs are NaN: their prediction would need samples
from before the record.

Reference: the definition ``e[t] = (z[t] - sum_{k=1..p} a[k] z[t - k]) / scale``, defined for
``t >= p`` only, computed here sample by sample."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.stats.whiten import whiten


def _by_definition(z: np.ndarray, a: list[float], scale: float) -> np.ndarray:
    p = len(a)
    e = np.full(z.shape[0], np.nan)
    for t in range(p, z.shape[0]):
        e[t] = (z[t] - sum(a[k - 1] * z[t - k] for k in range(1, p + 1))) / scale
    return e


@pytest.mark.parametrize("a", [[0.6], [0.5, -0.2], [0.4, 0.1, -0.3]])
def test_the_first_p_samples_are_blanked_and_the_rest_is_the_definition(a):
    """AR(p) coefficients ``a`` (p = 1, 2, 3) on 50 normal samples, scale 0.8: outputs
    ``0 .. p-1`` are NaN (a zero history assumed before the record would make them
    finite), outputs from ``p`` on are the definition's to 1e-12; asked for the samples
    after a history of ``p``, every one is finite."""
    z = np.random.default_rng(3).standard_normal(50)
    p = len(a)
    got = whiten(z, a, 0.8, 0)
    assert np.isnan(got[:p]).all()
    np.testing.assert_allclose(got, _by_definition(z, a, 0.8), rtol=0, atol=1e-12)
    after = whiten(z, a, 0.8, p)
    assert np.isfinite(after).all()
    np.testing.assert_allclose(after, _by_definition(z, a, 0.8)[p:], rtol=0, atol=1e-12)

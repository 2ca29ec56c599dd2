"""A channel computed from others (s6 = 0.5 s0 + 2 s3 - s5, written with 9 significant
digits) is no exact combination, so the AR regression had full rank; the bank then said
"no stabilizing solution" and the detection filter "0 finite training samples" (1200
were there). The fit names the dependent channels now (signal-pathology probe)."""

import numpy as np
import pytest

from analyzer.detectors.ar_model import fit_ar
from analyzer.errors import DetectorError
from analyzer.simulate import simulate_building


def _building():
    _, y, names = simulate_building(3, 12.0, 100.0, seed=1, sensors_per_floor=2)
    return y, names


def test_a_computed_channel_is_named_with_the_channels_it_combines():
    y, names = _building()
    s6 = 0.5 * y[:, 0] + 2 * y[:, 3] - y[:, 5]
    y = np.column_stack([y, np.array([float(f"{v:.9g}") for v in s6])])
    with pytest.raises(DetectorError) as err:
        fit_ar(y, 4, [*names, "s6"])
    assert "s0, s3, s5, s6 are linearly dependent" in str(err.value)
    assert "--channels '!s6'" in str(err.value)


def test_near_duplicates_with_their_own_noise_are_fitted():
    """A twin of s2 with noise of its own (1e-4 of its sd) is no exact combination: the
    fit keeps all 7 channels, with a full-rank innovation covariance (what the bank's
    Riccati solution needs) in which the twin's innovation is s2's, and a stable model."""
    y, names = _building()
    rng = np.random.default_rng(0)
    twin = y[:, 2] + 1e-4 * y[:, 2].std() * rng.standard_normal(y.shape[0])
    model = fit_ar(np.column_stack([y, twin]), 4, [*names, "s6"])
    assert (model.m, model.order) == (7, 4)
    assert np.isfinite(model.coefs).all()
    assert np.linalg.eigvalsh(model.sigma).min() > 0.0
    s = model.sigma
    assert s[2, 6] / np.sqrt(s[2, 2] * s[6, 6]) > 0.9999
    assert np.abs(np.linalg.eigvals(model.companion()[0])).max() < 1.0


def test_a_copy_rounded_to_float32_is_named_as_dependent():
    """The same signal logged twice, once as float32 (relative noise ~6e-8): a copy."""
    y, names = _building()
    copy = y[:, 2].astype(np.float32).astype(np.float64)
    with pytest.raises(DetectorError, match=r"s2, s6 are linearly dependent"):
        fit_ar(np.column_stack([y, copy]), 4, [*names, "s6"])

"""Scattered losses in the training window (a fifth of one sensor's samples, dropped
packets) leave few rows with a complete lag history: the relation fit said "the target
sensor is constant in the training window" (the variance of no rows) of a sensor that
was not constant (signal-pathology probe). It says what is short now."""

import numpy as np
import pytest

from analyzer.detectors.assistant_observer import fit_relation
from analyzer.errors import DetectorError


def test_scattered_gaps_are_named_not_taken_for_a_constant_sensor():
    rng = np.random.default_rng(3)
    y = rng.standard_normal((1200, 3))
    y[:, 0] += y[:, 1] + y[:, 2]
    y[rng.random(1200) < 0.2, 2] = np.nan
    with pytest.raises(DetectorError, match=r"of 1200 training rows have every lagged value"):
        fit_relation(y, 0, [1, 2], lags=64, max_lags=64)
    fit_relation(y[:, :2], 0, [1], lags=64, max_lags=64)  # without the gappy sensor: fitted

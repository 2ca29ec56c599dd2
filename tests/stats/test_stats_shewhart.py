"""Shewhart chart of the standardized innovation (seed 003, slide 52/94 and the practical
case's "225 outliers ... within the significance level")."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from analyzer.errors import DetectorError
from analyzer.stats import shewhart


def test_mask_count_and_fraction() -> None:
    x = np.array([0.0, 3.5, -4.0, 1.0, np.nan, 3.0, -3.0])
    result = shewhart(x)
    assert result.outliers.tolist() == [False, True, True, False, False, False, False]
    assert result.count == 2
    assert result.n == 6
    assert result.fraction == result.statistic == pytest.approx(2 / 6)
    assert result.critical == pytest.approx(0.0027, abs=1e-6)  # 0.27 % at k = 3
    assert result.pvalue == pytest.approx(stats.binom.sf(1, 6, 2 * stats.norm.sf(3)))
    assert result.reject


def test_practical_case_225_outliers_in_1e5_samples_is_within_the_level() -> None:
    # Seed 003's temperature case: 225 outliers in 1e5 samples (0.22 %) against 0.27 %.
    x = np.zeros(100_000)
    x[:225] = 4.0
    result = shewhart(x)
    assert result.fraction == pytest.approx(0.00225)
    assert not result.reject
    assert result.pvalue is not None and result.pvalue > 0.99  # 225 is below the 270 expected


def test_gross_errors_are_rejected() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=5000)
    x[rng.choice(5000, 50, replace=False)] += rng.choice([-6.0, 6.0], 50)  # 1 % gross errors
    result = shewhart(x)
    assert result.reject
    assert result.count >= 50


def test_other_limit_and_component_wise_matrix() -> None:
    x = np.random.default_rng(1).normal(size=(400, 3))
    result = shewhart(x, k=2.0)
    assert result.outliers.shape == (400, 3)
    assert result.critical == pytest.approx(0.0455, abs=1e-4)
    assert result.count == int((np.abs(x) > 2.0).sum())
    assert result.n == 1200
    assert result.as_dict()["k"] == 2.0


def test_result_arrays_are_read_only() -> None:
    result = shewhart(np.zeros(10))
    with pytest.raises(ValueError, match="read-only"):
        result.outliers[0] = True


def test_bad_input_raises() -> None:
    with pytest.raises(DetectorError, match=r"expected a finite k > 0, got -1"):
        shewhart(np.zeros(10), k=-1)
    with pytest.raises(DetectorError, match=r"expected a finite k > 0, got nan"):
        shewhart(np.zeros(10), k=float("nan"))
    with pytest.raises(DetectorError, match=r"all 4 values of x are NaN"):
        shewhart(np.full(4, np.nan))
    with pytest.raises(DetectorError, match=r"shape \(2, 2, 2\)"):
        shewhart(np.zeros((2, 2, 2)))
    with pytest.raises(DetectorError, match=r"x is empty"):
        shewhart([])

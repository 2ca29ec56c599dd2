"""Anderson-Darling and Cramer-von Mises: pinned to scipy, to closed forms and to the
slides' formulas (seed 003, slide 61/94 and following)."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy import stats

from analyzer.errors import DetectorError
from analyzer.stats import anderson_darling, cramer_von_mises

SAMPLES = {
    "normal-8": np.random.default_rng(1).normal(size=8),
    "normal-100": np.random.default_rng(2).normal(0.3, 2.0, size=100),
    "normal-5000": np.random.default_rng(3).normal(size=5000),
    "exponential-200": np.random.default_rng(4).exponential(size=200),
    "uniform-1000": np.random.default_rng(5).uniform(-2, 2, size=1000),
    "heavy-tail-1000": np.random.default_rng(6).standard_t(2, size=1000),
}


def scipy_anderson(x: np.ndarray) -> float:
    """``scipy.stats.anderson(x, "norm").statistic`` (A^2 with estimated parameters)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FutureWarning)  # scipy >= 1.17 asks for `method`
        return float(stats.anderson(x, "norm").statistic)


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_anderson_darling_case2_raw_equals_scipy(name: str) -> None:
    x = SAMPLES[name]
    result = anderson_darling(x, case=2)
    assert result.raw == pytest.approx(scipy_anderson(x), rel=1e-12)
    n = x.shape[0]
    assert result.statistic == pytest.approx(result.raw * (1 + 4 / n - 25 / n**2), rel=1e-15)
    assert result.critical == 0.787
    assert result.reject == (result.statistic > 0.787)
    assert result.pvalue is not None and 0.0 <= result.pvalue <= 1.0  # test_normality_pvalues
    assert result.n == n


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_anderson_darling_case1_matches_the_slide_formula(name: str) -> None:
    # Slide 61/94 writes the sum as (2i - 1) ln Phi(y_i) + (2(N - i) + 1) ln(1 - Phi(y_i)):
    # the same A^2 as the kernel's (2i - 1)[ln Phi(y_i) + ln(1 - Phi(y_(N+1-i)))].
    y = np.sort(SAMPLES[name])
    n = y.shape[0]
    i = np.arange(1, n + 1)
    terms = (2 * i - 1) * stats.norm.logcdf(y) + (2 * (n - i) + 1) * stats.norm.logsf(y)
    slide = -n - np.sum(terms) / n
    result = anderson_darling(y[::-1], case=1)  # order of the input does not matter
    assert result.raw == pytest.approx(slide, rel=1e-10)
    assert result.statistic == result.raw
    assert result.critical == 2.492


def test_case1_on_a_sample_with_mean_0_and_std_1_equals_case2() -> None:
    x = SAMPLES["exponential-200"]
    x = (x - x.mean()) / x.std(ddof=1)
    assert anderson_darling(x, 1).raw == pytest.approx(anderson_darling(x, 2).raw, rel=1e-12)
    assert cramer_von_mises(x, 1).raw == pytest.approx(cramer_von_mises(x, 2).raw, rel=1e-12)


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_cramer_von_mises_case1_raw_equals_scipy(name: str) -> None:
    x = SAMPLES[name]
    result = cramer_von_mises(x, case=1)
    assert result.raw == pytest.approx(stats.cramervonmises(x, "norm").statistic, rel=1e-12)
    n = x.shape[0]
    modified = (result.raw - 0.4 / n + 0.6 / n**2) * (1 + 1 / n)
    assert result.statistic == pytest.approx(modified, rel=1e-15)
    assert result.critical == 0.461
    assert result.reject == (result.statistic > 0.461)


@pytest.mark.parametrize("name", sorted(SAMPLES))
def test_cramer_von_mises_case2_is_scipy_on_the_standardized_sample(name: str) -> None:
    x = SAMPLES[name]
    standardized = (x - x.mean()) / x.std(ddof=1)
    result = cramer_von_mises(x, case=2)
    expected = stats.cramervonmises(standardized, "norm").statistic
    assert result.raw == pytest.approx(expected, rel=1e-12)
    assert result.statistic == pytest.approx(result.raw * (1 + 0.5 / x.shape[0]), rel=1e-15)
    assert result.critical == 0.126


@pytest.mark.parametrize("n", [8, 50, 1000])
def test_cramer_von_mises_minimum_at_the_plotting_positions(n: int) -> None:
    # W^2 = 1/(12N) + sum((2i-1)/(2N) - Phi(y_i))^2 is smallest, 1/(12N), when
    # Phi(y_i) = (2i-1)/(2N) exactly.
    y = stats.norm.ppf((2 * np.arange(1, n + 1) - 1) / (2 * n))
    assert cramer_von_mises(y, 1).raw == pytest.approx(1 / (12 * n), rel=1e-9)


@pytest.mark.parametrize("n", [8, 40, 1000])
def test_all_zero_sample_in_case1_has_closed_forms(n: int) -> None:
    # Phi(0) = 1/2 everywhere: A^2 = N (2 ln 2 - 1) and W^2 = N / 12.
    zeros = np.zeros(n)
    assert anderson_darling(zeros, 1).raw == pytest.approx(n * (2 * math.log(2) - 1), rel=1e-12)
    assert cramer_von_mises(zeros, 1).raw == pytest.approx(n / 12, rel=1e-12)


def test_constant_sample_in_case2_is_rejected_with_infinite_statistic() -> None:
    for test in (anderson_darling, cramer_von_mises):
        result = test(np.full(50, 0.7), case=2)
        assert result.statistic == math.inf
        assert result.reject
        assert result.as_dict()["statistic"] is None


@pytest.mark.parametrize("name", ["exponential-200", "uniform-1000", "heavy-tail-1000"])
def test_non_gaussian_samples_are_rejected_in_both_cases(name: str) -> None:
    x = SAMPLES[name]
    x = (x - x.mean()) / x.std()  # right mean and variance, wrong shape
    for test in (anderson_darling, cramer_von_mises):
        assert test(x, case=1).reject, test.__name__
        assert test(x, case=2).reject, test.__name__


def test_nan_samples_are_dropped() -> None:
    x = SAMPLES["normal-100"].copy()
    with_gaps = np.insert(x, [3, 50, 50], np.nan)
    for test in (anderson_darling, cramer_von_mises):
        for case in (1, 2):
            assert test(with_gaps, case) == test(x, case)
            assert test(with_gaps, case).n == 100


@pytest.mark.parametrize("test", [anderson_darling, cramer_von_mises])
def test_bad_input_raises(test: object) -> None:
    assert callable(test)
    with pytest.raises(DetectorError, match=r"at least 8 finite samples, got 7"):
        test(np.arange(7.0))
    with pytest.raises(DetectorError, match=r"at least 8 finite samples, got 3"):
        test([1.0, np.nan, 2.0, np.nan, 3.0, np.nan, np.nan, np.nan, np.nan])
    with pytest.raises(DetectorError, match=r"all 20 values of x are NaN"):
        test(np.full(20, np.nan))
    with pytest.raises(DetectorError, match=r"1-D standardized innovation .* shape \(10, 2\)"):
        test(np.zeros((10, 2)))
    with pytest.raises(DetectorError, match=r"expected case 1 .* or 2 .*, got 3"):
        test(np.zeros(10), case=3)
    with pytest.raises(DetectorError, match=r"x is empty"):
        test(np.array([]))
    with pytest.raises(DetectorError, match=r"expected numeric samples for x"):
        test(["a", "b"])

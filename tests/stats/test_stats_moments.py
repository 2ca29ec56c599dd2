"""Mean and covariance tests and the standardization eta = S^{-1/2} e (seed 003, "LDS -
Statistics of the innovation sequence", "Tests of mean", "Tests of covariance")."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from analyzer.errors import DetectorError
from analyzer.stats import covariance_test, inverse_sqrt, mean_test, standardize

S2 = np.array([[4.0, 1.2], [1.2, 1.0]])
S3 = np.array([[2.0, 0.3, -0.4], [0.3, 1.0, 0.2], [-0.4, 0.2, 0.5]])


@pytest.mark.parametrize(("n", "reject"), [(400, True), (300, False)])
def test_mean_test_threshold_is_196_over_sqrt_n(n: int, reject: bool) -> None:
    # |mean| = 0.1 against 1.96/sqrt(N): 0.098 at N=400 (reject), 0.113 at N=300 (keep).
    x = np.full(n, 0.1)
    result = mean_test(x)
    assert result.statistic == pytest.approx(0.1 * np.sqrt(n))
    assert result.critical == pytest.approx(1.96, abs=5e-5)
    assert result.reject is reject
    assert result.pvalue == pytest.approx(2 * stats.norm.sf(0.1 * np.sqrt(n)))
    assert result.n == n


def test_mean_test_per_component() -> None:
    rng = np.random.default_rng(0)
    x = rng.normal(size=(1000, 3))
    x -= x.mean(axis=0) - [0.01, 0.3, -0.02]  # component 1 shifted, the others not
    result = mean_test(x)
    assert result.per_component.tolist() == [False, True, False]
    assert result.reject
    np.testing.assert_allclose(result.mean, x.mean(axis=0))
    np.testing.assert_allclose(result.z, np.sqrt(1000) * x.mean(axis=0))
    assert result.statistic == pytest.approx(np.abs(result.z).max())
    assert result.as_dict()["per_component"] == [False, True, False]


def test_covariance_statistic_is_trace_of_n_c0() -> None:
    rng = np.random.default_rng(1)
    x = rng.normal(size=(500, 2))
    result = covariance_test(x)
    c0 = x.T @ x / 500
    assert result.statistic == pytest.approx(np.trace(500 * c0), rel=1e-12)
    assert result.dof == 1000
    assert result.critical == pytest.approx(stats.chi2.ppf(0.975, 1000))
    assert result.critical_low == pytest.approx(stats.chi2.ppf(0.025, 1000))
    tail = min(stats.chi2.cdf(result.statistic, 1000), stats.chi2.sf(result.statistic, 1000))
    assert result.pvalue == pytest.approx(2 * tail)
    assert result.reject == (not result.critical_low <= result.statistic <= result.critical)
    assert result.ratio == pytest.approx(result.statistic / 1000)


@pytest.mark.parametrize(("scale", "reject"), [(1.0, False), (np.sqrt(1.5), True), (0.7, True)])
def test_covariance_test_is_two_sided(scale: float, reject: bool) -> None:
    x = scale * np.random.default_rng(2).normal(size=1000)
    assert covariance_test(x).reject is reject


def test_inverse_sqrt_of_a_covariance() -> None:
    for s in (S2, S3):
        root = inverse_sqrt(s)
        np.testing.assert_allclose(root, root.T, atol=1e-14)
        np.testing.assert_allclose(root @ s @ root, np.eye(s.shape[0]), atol=1e-12)
        np.testing.assert_allclose(root @ root, np.linalg.inv(s), rtol=1e-12, atol=1e-12)


def test_standardized_innovation_has_identity_covariance() -> None:
    rng = np.random.default_rng(3)
    e = rng.multivariate_normal([0.0, 0.0, 0.0], S3, size=20000)
    eta = standardize(e, S3)
    assert eta.shape == e.shape
    np.testing.assert_allclose(np.cov(eta.T), np.eye(3), atol=0.04)
    assert not covariance_test(eta).reject
    assert covariance_test(e).reject


def test_time_varying_covariance_stack() -> None:
    rng = np.random.default_rng(4)
    e = rng.normal(size=(6, 2))
    stack = np.stack([S2 * (1 + k) for k in range(6)])
    eta = standardize(e, stack)
    for k in range(6):
        np.testing.assert_allclose(eta[k], standardize(e[k : k + 1], stack[k])[0], rtol=1e-12)


def test_one_channel_with_scalar_or_per_sample_variance() -> None:
    e = np.array([2.0, -4.0, 6.0])
    np.testing.assert_allclose(standardize(e, 4.0), e / 2)
    np.testing.assert_allclose(standardize(e, [[4.0]]), e / 2)
    np.testing.assert_allclose(standardize(e, [1.0, 4.0, 9.0]), [2.0, -2.0, 2.0])
    np.testing.assert_allclose(standardize(e[:, None], 4.0), (e / 2)[:, None])


def test_bad_covariance_raises() -> None:
    e = np.zeros((10, 2))
    with pytest.raises(DetectorError, match=r"not symmetric: max \|S - S\^T\| = 0.5"):
        standardize(e, [[1.0, 0.5], [0.0, 1.0]])
    with pytest.raises(DetectorError, match=r"not positive definite: smallest eigenvalue -1"):
        standardize(e, [[1.0, 2.0], [2.0, 1.0]])
    with pytest.raises(DetectorError, match=r"smallest eigenvalue -1 \(at S\[3\]\)"):
        standardize(np.zeros(5), [1.0, 2.0, 3.0, -1.0, 1.0])
    with pytest.raises(DetectorError, match=r"expected S of shape \(2, 2\) or \(10, 2, 2\)"):
        standardize(e, np.eye(3))
    with pytest.raises(DetectorError, match=r"S has 1 non-finite entries"):
        standardize(e, [[1.0, np.nan], [0.0, 1.0]])
    with pytest.raises(DetectorError, match=r"square \(r, r\) or \(N, r, r\) matrix for S"):
        inverse_sqrt(np.ones((2, 3)))
    with pytest.raises(DetectorError, match=r"\(N,\) or \(N, r\) innovation for E"):
        standardize(np.zeros((2, 2, 2)), np.eye(2))


def test_bad_samples_raise() -> None:
    for test in (mean_test, covariance_test):
        with pytest.raises(DetectorError, match=r"all 6 values of x are NaN"):
            test(np.full((3, 2), np.nan))
        with pytest.raises(
            DetectorError, match=r"\(N,\) or \(N, r\) innovation matrix .*\(2, 2, 2\)"
        ):
            test(np.zeros((2, 2, 2)))
        with pytest.raises(DetectorError, match=r"x is empty"):
            test(np.zeros((0, 3)))


def test_rows_with_nan_are_dropped() -> None:
    x = np.random.default_rng(5).normal(size=(100, 2))
    gapped = np.vstack([x[:50], [[np.nan, 1.0]], x[50:]])
    assert mean_test(gapped).n == 100
    np.testing.assert_array_equal(mean_test(gapped).mean, mean_test(x).mean)
    assert covariance_test(gapped).statistic == pytest.approx(covariance_test(x).statistic)


def _ar1(seed: int, n: int = 3000, phi: float = 0.8) -> np.ndarray:
    """A strongly autocorrelated series (AR(1), ``phi`` 0.8) with a mean of 0.3."""
    from scipy.signal import lfilter

    e = np.random.default_rng(seed).standard_normal(n)
    return lfilter([1.0], [1.0, -phi], e) + 0.3


@pytest.mark.parametrize("lags", [0, 1, 2, 5, 20])
def test_long_run_variance_is_statsmodels_hac(lags: int) -> None:
    """Newey-West's long-run variance over ``lags`` lags is ``N`` times statsmodels' HAC
    variance of the mean (Bartlett kernel, no small-sample correction): the weights
    ``1 - k / (L + 1)`` (test audit ux65 S11: ``1 - k / L`` passed tests/stats)."""
    import statsmodels.api as sm  # a dependency (pyproject.toml): no skip
    from statsmodels.stats.sandwich_covariance import cov_hac

    from analyzer.stats.moments import long_run_variance

    x = _ar1(lags)
    fit = sm.OLS(x, np.ones((x.shape[0], 1))).fit()
    hac = float(cov_hac(fit, nlags=lags, use_correction=False)[0, 0])
    assert long_run_variance(x, lags) / x.shape[0] == pytest.approx(hac, rel=1e-10)


def test_bartlett_sum_weighs_lag_k_of_l_by_one_minus_k_over_l_plus_one() -> None:
    """Each lag alone: ``a_0 + 2 (1 - k / (L + 1)) a_k``, by hand."""
    from analyzer.stats.moments import bartlett_sum

    assert bartlett_sum(np.array([2.0])) == 2.0
    for top in (1, 2, 3, 7):
        for k in range(1, top + 1):
            acov = np.zeros(top + 1)
            acov[0], acov[k] = 1.0, 1.0
            assert bartlett_sum(acov) == pytest.approx(1.0 + 2.0 * (1.0 - k / (top + 1.0)))

"""Whiteness: autocorrelation pinned to statsmodels' acf, Ljung-Box Q and p pinned to
statsmodels' acorr_ljungbox, band 1.96/sqrt(N) (seed 003, "Tests of whiteness")."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats
from statsmodels.stats.diagnostic import acorr_ljungbox
from statsmodels.tsa.stattools import acf as sm_acf

from analyzer.errors import DetectorError
from analyzer.stats import autocorrelation, whiteness


def ar1(phi: float, n: int, seed: int) -> np.ndarray:
    """AR(1) innovations x_t = phi x_{t-1} + e_t scaled to unit variance."""
    e = np.random.default_rng(seed).normal(size=n)
    return signal.lfilter([np.sqrt(1 - phi**2)], [1.0, -phi], e)


CASES = [(50, 1, 0), (500, 5, 1), (1000, 20, 2), (2000, 40, 3)]


@pytest.mark.parametrize(("n", "lags", "seed"), CASES)
def test_acf_equals_statsmodels(n: int, lags: int, seed: int) -> None:
    x = np.random.default_rng(seed).normal(0.5, 2.0, size=n)
    expected = sm_acf(x, nlags=lags, fft=False)[1:]
    np.testing.assert_allclose(autocorrelation(x, lags), expected, rtol=1e-10, atol=1e-14)
    np.testing.assert_allclose(whiteness(x, lags).acf, expected, rtol=1e-10, atol=1e-14)


@pytest.mark.parametrize(("n", "lags", "seed"), CASES)
@pytest.mark.parametrize("phi", [0.0, 0.3])
def test_ljung_box_equals_statsmodels(n: int, lags: int, seed: int, phi: float) -> None:
    x = ar1(phi, n, seed)
    result = whiteness(x, lags)
    expected = acorr_ljungbox(x, lags=[lags])
    assert result.statistic == pytest.approx(expected["lb_stat"].iloc[0], rel=1e-10)
    assert result.ljung_box == result.statistic
    assert result.pvalue is not None
    assert result.pvalue == pytest.approx(expected["lb_pvalue"].iloc[0], rel=1e-9, abs=1e-300)
    assert result.critical == pytest.approx(stats.chi2.ppf(0.95, lags), rel=1e-14)
    assert result.reject == (result.pvalue < 0.05)
    assert result.n == n and result.lags == lags


def test_band_and_fraction_outside() -> None:
    x = ar1(0.2, 400, 7)
    result = whiteness(x, 20)
    assert result.band == pytest.approx(1.96 / np.sqrt(400), rel=1e-4)
    outside = np.abs(sm_acf(x, nlags=20, fft=False)[1:]) > 1.959963984540054 / 20
    assert result.band_fraction == pytest.approx(outside.mean())
    assert 0 < result.band_fraction < 1  # lag 1 (~0.2) is outside, far lags are not


@pytest.mark.parametrize("seed", range(30))
def test_ar1_with_phi_half_is_rejected(seed: int) -> None:
    result = whiteness(ar1(0.5, 1000, seed), 20)
    assert result.reject
    assert result.acf[0] == pytest.approx(0.5, abs=0.1)
    assert result.band_fraction >= 0.05


def test_constant_sample_has_no_autocorrelation_and_does_not_reject() -> None:
    result = whiteness(np.full(100, 0.1), 10)
    assert np.isnan(result.acf).all()
    assert np.isnan(result.statistic) and np.isnan(result.pvalue or 0.0)
    assert not result.reject
    assert result.as_dict()["statistic"] is None


def test_nan_samples_are_dropped() -> None:
    x = ar1(0.0, 300, 11)
    gapped = np.insert(x, [0, 150], np.nan)
    assert whiteness(gapped, 10).statistic == whiteness(x, 10).statistic
    assert whiteness(gapped, 10).n == 300


def test_bad_input_raises() -> None:
    with pytest.raises(DetectorError, match=r"more than lags=20 finite samples, got 20"):
        whiteness(np.zeros(20), 20)
    with pytest.raises(DetectorError, match=r"expected lags >= 1, got 0"):
        whiteness(np.zeros(50), 0)
    with pytest.raises(DetectorError, match=r"expected an integer lags, got 2.5"):
        whiteness(np.zeros(50), 2.5)  # type: ignore[arg-type]
    with pytest.raises(DetectorError, match=r"all 30 values of x are NaN"):
        whiteness(np.full(30, np.nan), 5)
    with pytest.raises(DetectorError, match=r"shape \(50, 2\)"):
        whiteness(np.zeros((50, 2)), 5)
    with pytest.raises(DetectorError, match=r"at least 6 finite samples, got 5"):
        autocorrelation(np.zeros(5), 5)


@pytest.mark.parametrize(("n", "max_lag"), [(1, 3), (7, 3), (7, 50), (1000, 200), (48_001, 200)])
def test_lagged_products_equal_the_direct_sums(n, max_lag):
    """The FFT over ``n + max_lag`` points (no wrapped-around terms) gives the direct
    ``sum_t d[t] d[t + k]``, including where ``max_lag`` is past the series."""
    from analyzer.stats.whiteness import lagged_products

    d = np.random.default_rng(n).standard_normal(n)
    d[: n // 3] += 2.0  # uncentred: the sums are of the series as given
    top = min(max_lag, n - 1)
    direct = np.array([d[: n - k] @ d[k:] for k in range(top + 1)])
    got = lagged_products(d, max_lag)
    assert got.shape == (top + 1,)
    np.testing.assert_allclose(got, direct, rtol=0, atol=1e-12 * float(d @ d))


@pytest.mark.parametrize("n", [30, 100])
def test_default_lags_keep_the_level_on_short_segments(n: int) -> None:
    """Audit: 20 lags on a white segment of 30 samples rejected 8.8 % of the time at
    the 5 % level (7.2 % at 100, 6.3 % at 200; the evidence tests segments from 30
    samples): the default is at most N / 20 lags (10,000 replications: 5.0 % at 100,
    5.6 % at 200 and 300, 5.5 % at 400, 5.45 % with 20 lags at 1000)."""
    rng = np.random.default_rng(n)
    x = rng.standard_normal((4000, n))
    rate = np.mean([whiteness(row).reject for row in x])
    assert 0.04 < rate < 0.065  # (0.34 % standard error)
    assert whiteness(x[0]).lags == max(1, n // 20)
    assert whiteness(rng.standard_normal(5000)).lags == 20

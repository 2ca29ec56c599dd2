"""The compiled kernel of windowed_tests agrees with its numpy path (to 1e-9 relative, same
decisions), its normal CDF and log-CDF and its A^2 and W^2 agree with scipy's, it is
thread-safe, and the module works without numba."""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pytest
from scipy.special import log_ndtr, ndtr
from scipy.stats import chi2

import analyzer.stats.windowed as windowed
from analyzer.errors import DetectorError
from analyzer.stats import _windowed_kernel
from analyzer.stats._checks import ALPHA
from analyzer.stats.normality import (
    anderson_darling_sorted,
    cramer_von_mises_sorted,
    modify_anderson_darling,
    modify_cramer_von_mises,
    standardize_sorted,
)
from analyzer.stats.whiteness import autocorrelation
from analyzer.stats.windowed import WindowedTests, WindowStats, windowed_tests

pytest.importorskip("numba")

REPO = Path(__file__).resolve().parents[2]

RTOL = 1e-9
ATOL = 1e-12
"""Absolute floor, for statistics that cross zero (window means)."""

ACF_ATOL = 1e-10
"""Absolute tolerance of the autocorrelations: the numpy path takes each c_k as the
difference of prefix sums over a batch, which costs it up to ~1e-10 absolute where the
samples are large (the 40-sigma errors here); the kernel sums about the window mean and
matches the scalar autocorrelation to ~1e-15 (checked below)."""


def residual(n: int, seed: int) -> np.ndarray:
    """White noise with drift, a 10-sigma offset, gross errors (some beyond 30 sigma, the
    asymptotic branch of ln Phi), stuck stretches covering whole and partial windows, a
    noisy stretch, NaN and inf gaps."""
    rng = np.random.default_rng(seed)
    z = rng.normal(size=n) + np.linspace(0.0, 2.0, n)
    z[n // 6 : n // 6 + 900] += 10.0
    z[rng.choice(n, n // 150, replace=False)] += rng.choice([-45.0, -6.0, 5.0, 40.0], n // 150)
    z[2 * n // 3 : 2 * n // 3 + 1_200] *= 1.8
    z[rng.choice(n, 12, replace=False)] = np.nan
    z[[77, 5_000]] = [np.inf, -np.inf]
    z[n // 3 + 50 : n // 3 + 2_200] = 0.25
    z[n // 2 + 17 : n // 2 + 17 + 333] = -1.5
    return z


def fallback(monkeypatch: pytest.MonkeyPatch, *args: object, **kwargs: object) -> WindowedTests:
    """windowed_tests by its numpy path (which warns of inf - inf in windows holding an
    inf; those windows are reported as untested)."""
    with monkeypatch.context() as patch, np.errstate(invalid="ignore"):
        patch.setattr(windowed, "window_kernel", None)
        return windowed_tests(*args, **kwargs)  # type: ignore[arg-type]


def assert_close(a: np.ndarray, b: np.ndarray, name: str, atol: float = ATOL) -> None:
    np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=name)
    np.testing.assert_allclose(a, b, rtol=RTOL, atol=atol, equal_nan=True, err_msg=name)


def assert_same_decisions(a: WindowStats, b: WindowStats, name: str) -> None:
    """Identical rejections, except where a statistic (or p-value) is within 1e-9 of the
    critical value (or of ALPHA)."""
    near = np.isclose(a.statistic, a.critical, rtol=RTOL, atol=0.0)
    if a.critical_low is not None:
        near |= np.isclose(a.statistic, a.critical_low, rtol=RTOL, atol=0.0)
    if a.pvalue is not None:
        near |= np.isclose(a.pvalue, ALPHA, rtol=RTOL, atol=0.0)
    differ = a.reject != b.reject
    assert not (differ & ~near).any(), (name, np.flatnonzero(differ & ~near))


def assert_same(kernel: WindowedTests, numpy: WindowedTests) -> None:
    np.testing.assert_array_equal(kernel.start, numpy.start)
    np.testing.assert_array_equal(kernel.valid, numpy.valid)
    np.testing.assert_array_equal(kernel.outliers, numpy.outliers)
    assert_close(kernel.means, numpy.means, "means")
    assert_close(kernel.band_fraction, numpy.band_fraction, "band_fraction")
    assert (kernel.acf is None) == (numpy.acf is None)
    if kernel.acf is not None and numpy.acf is not None:
        assert_close(kernel.acf, numpy.acf, "acf", ACF_ATOL)
    for name in WindowedTests.TESTS:
        a, b = getattr(kernel, name), getattr(numpy, name)
        assert (a.critical, a.critical_low) == (b.critical, b.critical_low)
        assert_close(a.statistic, b.statistic, name)
        assert (a.pvalue is None) == (b.pvalue is None)
        if a.pvalue is not None:
            assert_close(a.pvalue, b.pvalue, name + " p-value")
        assert_same_decisions(a, b, name)


def test_kernel_is_used_with_one_signature() -> None:
    """Read-only, strided and float32 residuals share the one compiled specialization."""
    kernel = windowed.window_kernel
    assert kernel is not None
    z = np.random.default_rng(2).normal(size=4_000)
    z.flags.writeable = False
    for arg in (z, z[::2], z.astype(np.float32)):
        result = windowed_tests(arg, 100, keep_acf=True)
        assert result.valid.all()
    assert len(kernel.signatures) == 1  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    ("window", "step", "case", "lags", "k", "keep_acf", "batch_values"),
    [
        (100, None, 1, 20, 3.0, True, 1 << 16),  # the pipeline's setting
        (100, None, 2, 20, 3.0, False, 1 << 16),
        (250, 60, 1, 20, 3.0, True, 1_000),  # overlapping, many batches
        (250, 60, 2, 7, 2.5, True, 3_000),
        (120, 400, 2, 20, 3.0, False, 2_000),  # gaps between windows
        (333, 41, 1, 30, 4.0, True, 1),  # one window per batch
        (21, 5, 2, 20, 3.0, True, 500),  # smallest window for 20 lags
        (1_000, 1_000, 2, 20, 3.0, True, 1 << 20),
    ],
)
def test_kernel_equals_numpy_path(
    monkeypatch: pytest.MonkeyPatch,
    window: int,
    step: int | None,
    case: int,
    lags: int,
    k: float,
    keep_acf: bool,
    batch_values: int,
) -> None:
    z = residual(30_000, seed=window + case)
    args = (z, window, step)
    kwargs = {"lags": lags, "k": k, "case": case, "keep_acf": keep_acf}
    kernel = windowed_tests(*args, batch_values=batch_values, **kwargs)  # type: ignore[arg-type]
    numpy = fallback(monkeypatch, *args, batch_values=1 << 16, **kwargs)
    assert_same(kernel, numpy)
    assert not kernel.valid.all() and kernel.valid.mean() > 0.5
    if case == 2:  # stuck windows are rejected with an infinite statistic
        stuck = kernel.anderson_darling.statistic == np.inf
        assert stuck.any() and kernel.whiteness.pvalue is not None
        assert np.isnan(kernel.whiteness.pvalue[stuck]).all()


def test_kernel_acf_equals_scalar_autocorrelation() -> None:
    z = residual(30_000, seed=11)
    result = windowed_tests(z, 100, 37, lags=20, keep_acf=True)
    assert result.acf is not None
    checked = 0
    for i in range(0, result.n_windows, 3):
        segment = z[result.start[i] : result.start[i] + 100]
        if result.valid[i] and segment.min() < segment.max():
            expected = autocorrelation(segment, 20)
            np.testing.assert_allclose(result.acf[i], expected, rtol=1e-12, atol=1e-14)
            checked += 1
    assert checked > 200


def test_kernel_batches_do_not_change_the_result() -> None:
    z = residual(20_000, seed=5)
    one = windowed_tests(z, 200, 70, keep_acf=True, batch_values=1 << 20)
    many = windowed_tests(z, 200, 70, keep_acf=True, batch_values=1)
    for name in WindowedTests.TESTS:
        a, b = getattr(one, name), getattr(many, name)
        np.testing.assert_array_equal(a.statistic, b.statistic)
        np.testing.assert_array_equal(a.reject, b.reject)
    np.testing.assert_array_equal(one.acf, many.acf)


@pytest.mark.parametrize("batch_values", [1, 1000, 1 << 20])
def test_standardized_a_batch_at_a_time_equals_standardized_whole(tmp_path, batch_values):
    """``standardize=(mean, std)``: the raw residual (float32, memory-mapped, with a gap)
    standardized a batch at a time gives the tests of the residual standardized whole,
    bit for bit (the same two operations per sample), and its pages are given back."""
    from analyzer import paging

    rng = np.random.default_rng(11)
    raw = (0.3 + 2.5 * rng.standard_normal(20_017)).astype(np.float32)
    raw[5000:5040] = np.nan
    mapped = paging.buffer(tmp_path, "r", (raw.shape[0], 1), np.float32)[:, 0]
    mapped[:] = raw
    mean, std = 0.25, 2.4
    whole = np.subtract(raw, mean, dtype=np.float64)
    whole /= std
    want = windowed_tests(whole, 200, 70, keep_acf=True)
    for source in (raw, mapped):
        got = windowed_tests(
            source, 200, 70, keep_acf=True, batch_values=batch_values, standardize=(mean, std)
        )
        np.testing.assert_array_equal(got.start, want.start)
        for name in WindowedTests.TESTS:
            a, b = getattr(want, name), getattr(got, name)
            np.testing.assert_array_equal(a.statistic, b.statistic)
            np.testing.assert_array_equal(a.reject, b.reject)
        np.testing.assert_array_equal(got.acf, want.acf)
        np.testing.assert_array_equal(got.valid, want.valid)


@pytest.mark.parametrize("batch_values", [1, 1000, 1 << 20])
def test_whitened_a_batch_at_a_time_equals_whitened_whole(batch_values):
    """``whitening=(coefficients, scale)``: each batch reads the samples before it the
    filter needs, so the windows' tests are those of the residual standardized and
    whitened whole by the filter's definition (to rounding: a convolution), a gap and
    the record's first ``p`` samples leaving their windows untested."""
    rng = np.random.default_rng(12)
    raw = (0.3 + 2.5 * rng.standard_normal(20_017)).astype(np.float32)
    raw[5000:5040] = np.nan
    mean, std = 0.25, 2.4
    coefficients, scale = (0.6, -0.25, 0.1), 0.9
    z = (raw.astype(np.float64) - mean) / std
    e = np.full(z.shape[0], np.nan)
    for t in range(3, z.shape[0]):
        e[t] = (z[t] - 0.6 * z[t - 1] + 0.25 * z[t - 2] - 0.1 * z[t - 3]) / scale
    want = windowed_tests(e, 200, 70, keep_acf=True)
    got = windowed_tests(
        raw,
        200,
        70,
        keep_acf=True,
        batch_values=batch_values,
        standardize=(mean, std),
        whitening=(coefficients, scale),
    )
    np.testing.assert_array_equal(got.valid, want.valid)
    assert not got.valid[0]  # the first window holds the first p samples
    for name in WindowedTests.TESTS:
        a, b = getattr(want, name), getattr(got, name)
        np.testing.assert_allclose(a.statistic, b.statistic, rtol=1e-9, atol=1e-12)
        np.testing.assert_array_equal(a.reject, b.reject)
    with pytest.raises(DetectorError, match="standardize"):
        windowed_tests(raw, 200, whitening=(coefficients, scale))


def test_normal_logs_match_scipy() -> None:
    normal_logs = _windowed_kernel.normal_logs
    assert normal_logs is not None
    x = np.concatenate(
        [
            np.linspace(-40.0, 40.0, 4001),
            [-1e4, -500.0, -37.6, -30.0, -29.999999, -20.0, -1.0, -0.0, 0.0, 1e-300, 38.0],
        ]
    )
    got = np.array([normal_logs(float(v)) for v in x])
    np.testing.assert_allclose(got[:, 0], ndtr(x), rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(got[:, 1], log_ndtr(x), rtol=1e-13, atol=1e-16)
    np.testing.assert_allclose(got[:, 2], log_ndtr(-x), rtol=1e-13, atol=1e-16)


def test_threads_give_the_serial_result() -> None:
    zs = [residual(40_000, seed) for seed in range(4)]
    serial = [windowed_tests(z, 100, keep_acf=True) for z in zs]
    with ThreadPoolExecutor(4) as pool:
        threaded = list(pool.map(lambda z: windowed_tests(z, 100, keep_acf=True), zs))
    for a, b in zip(serial, threaded, strict=True):
        for name in WindowedTests.TESTS:
            np.testing.assert_array_equal(getattr(a, name).statistic, getattr(b, name).statistic)
        np.testing.assert_array_equal(a.acf, b.acf)


def test_works_without_numba() -> None:
    code = (
        "import sys; sys.modules['numba'] = None\n"
        "import numpy as np\n"
        "import analyzer.stats.windowed as w\n"
        "assert w.window_kernel is None\n"
        "r = w.windowed_tests(np.random.default_rng(0).normal(size=1000), 100)\n"
        "assert r.n_windows == 10 and r.valid.all()\n"
    )
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, check=True, timeout=120)


@pytest.mark.parametrize("case", [1, 2])
def test_kernel_normality_equals_log_ndtr_sums(case: int) -> None:
    """A^2 (products of Phi, four logs per window) and W^2 of the kernel equal scipy's
    ``log_ndtr``/``ndtr`` sums to 1e-11, also for windows of 5000 samples, for samples just
    inside the 20-sigma limit of the products, where their factors are smallest
    (Phi(-19.99) ~ 2^-294), and for samples beyond it (logs from normal_logs)."""
    rng = np.random.default_rng(case)
    z = rng.normal(size=60_000)
    z[rng.choice(20_000, 400, replace=False)] = rng.choice([-19.99, -17.5, 16.0, 19.99], 400)
    z[rng.choice(20_000, 40, replace=False)] = rng.choice([-45.0, -29.9, 20.0, 38.0], 40)
    for window in (100, 5_000):
        result = windowed_tests(z, window, case=case)
        block = np.sort(z[: result.n_windows * window].reshape(-1, window), axis=1)
        standardized, _ = standardize_sorted(block, case)
        expected_a2 = modify_anderson_darling(anderson_darling_sorted(standardized), window, case)
        expected_w2 = modify_cramer_von_mises(cramer_von_mises_sorted(standardized), window, case)
        np.testing.assert_allclose(result.anderson_darling.statistic, expected_a2, rtol=1e-11)
        np.testing.assert_allclose(result.cramer_von_mises.statistic, expected_w2, rtol=1e-11)
        assert (np.abs(standardized) > 19.0).any() == (case == 1)  # case 2: std grows


def test_two_sided_chi2_equals_both_tails() -> None:
    """The covariance p-value evaluates one tail away from the median: the same numbers
    as min(1, 2 min(cdf, sf)) everywhere, bit for bit."""
    df = 100
    x = np.concatenate(
        [
            chi2.ppf(np.linspace(0.0, 1.0, 2001), df),
            np.linspace(0.0, 400.0, 4001),
            [np.nan, np.inf, 0.0, 1e-300, 1e6],
        ]
    )
    expected = np.minimum(1.0, 2.0 * np.minimum(chi2.cdf(x, df), chi2.sf(x, df)))
    np.testing.assert_array_equal(windowed._two_sided_chi2(x, df), expected)

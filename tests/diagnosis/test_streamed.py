"""The healthy-series statistics taken a block at a time equal the whole-series
formulas (the ones calibration used before it streamed, restated here)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.lib.format import open_memmap
from scipy import signal

from analyzer.detectors.detection_filter import long_run_time
from analyzer.diagnosis import changes, streamed
from analyzer.diagnosis.changes import LONG_FACTOR, calibrate, moving_mean
from analyzer.diagnosis.classify import correlation_time
from analyzer.diagnosis.streamed import (
    BlockMeans,
    LaggedSums,
    RunningMoments,
    WindowSums,
    finite_blocks,
)
from analyzer.errors import DetectorError
from analyzer.stats.whiteness import lagged_products


def _whole_acf(z: np.ndarray, max_lag: int) -> np.ndarray:
    n = z.shape[0]
    acf = lagged_products(z - z.mean(), max_lag)
    acf = acf / acf[0]
    acf[1:][np.abs(acf[1:]) < 2.0 / np.sqrt(n)] = 0.0
    return acf


def whole_calibrate(r: np.ndarray, window: int, far: float) -> changes.Calibration:
    """calibrate as it was on the whole series (every copy held at once)."""
    r = r[np.isfinite(r)]
    windows = (window, LONG_FACTOR * window)
    mean = float(np.mean(r))
    std = float(np.std(r, ddof=1))
    z = (r - mean) / std
    rho = _whole_acf(z, windows[-1])
    z2 = z * z
    rho2 = _whole_acf(z2, windows[-1])
    var_z2 = float(np.var(z2))
    msd, lqm, lqs = [], [], []
    for w in windows:
        taper = 1.0 - np.arange(1, w) / w
        var_m = (1.0 + 2.0 * np.sum(taper * rho[1:w])) / w
        var_q = var_z2 * (1.0 + 2.0 * np.sum(taper * rho2[1:w])) / w
        m = moving_mean(z, w)[w - 1 :]
        logq = np.log(np.maximum(moving_mean(z * z, w)[w - 1 :], 1e-300))
        msd.append(max(float(np.std(m, ddof=1)), float(np.sqrt(max(var_m, 0.0)))))
        lqm.append(float(np.mean(logq)))
        lqs.append(max(float(np.std(logq, ddof=1)), float(np.sqrt(max(var_q, 0.0)))))
    return changes.Calibration(mean, std, window, windows, tuple(msd), tuple(lqm), tuple(lqs), far)


def whole_correlation_time(r: np.ndarray, max_lag: int = 200) -> float:
    x = r[np.isfinite(r)]
    x = x - x.mean()
    acf = lagged_products(x, max_lag)
    acf = acf / acf[0]
    neg = np.flatnonzero(acf[1:] <= 0.0)
    stop = int(neg[0]) + 1 if neg.size else acf.shape[0]
    return float(max(1.0, 1.0 + 2.0 * np.sum(acf[1:stop])))


def whole_long_run_time(r: np.ndarray, window: int) -> float:
    x = r[np.isfinite(r)]
    tau = whole_correlation_time(x)
    v = float(np.var(x))
    if not v > 0.0:
        return tau
    b = window
    while 8 * b <= x.shape[0]:
        nb = x.shape[0] // b
        means = x[: nb * b].reshape(nb, b).mean(axis=1)
        tau = max(tau, float(b * np.var(means, ddof=1) / v))
        b *= 2
    return tau


def _residual(n: int, seed: int, gaps: bool = True) -> np.ndarray:
    """A coloured residual (a lightly damped resonance and a slow wander) with an offset,
    and gaps."""
    rng = np.random.default_rng(seed)
    e = rng.standard_normal(n)
    x = signal.lfilter([1.0], [1.0, -1.6, 0.8], e) + 0.3 * signal.lfilter([1.0], [1.0, -0.999], e)
    x += 5.0
    if gaps:
        x[1000:1400] = np.nan
        x[rng.integers(0, n, 50)] = np.nan
    return x


@pytest.fixture(params=[None, 997, 4096])
def block(request, monkeypatch):
    """The default block and small ones (many block edges, one not a power of two)."""
    if request.param is not None:
        monkeypatch.setattr(streamed, "SERIES_BLOCK", request.param)
    return request.param


def _same_calibration(a: changes.Calibration, b: changes.Calibration) -> None:
    assert a.windows == b.windows
    np.testing.assert_allclose(a.mean, b.mean, rtol=1e-12)
    np.testing.assert_allclose(a.std, b.std, rtol=1e-12)
    np.testing.assert_allclose(a.mean_sd, b.mean_sd, rtol=1e-9)
    np.testing.assert_allclose(a.logq_mean, b.logq_mean, rtol=1e-9)
    np.testing.assert_allclose(a.logq_sd, b.logq_sd, rtol=1e-9)


def test_calibrate_equals_the_whole_series_formulas(block):
    r = _residual(60_000, 1)
    _same_calibration(calibrate(r, 25, 1e-4), whole_calibrate(r, 25, 1e-4))


def test_calibrate_of_parts_equals_their_concatenation(block):
    parts = [_residual(23_456, 2), _residual(31_001, 3, gaps=False), np.full(50, np.nan)]
    _same_calibration(calibrate(parts, 16, 1e-6), whole_calibrate(np.concatenate(parts), 16, 1e-6))


def test_correlation_times_equal_the_whole_series_formulas(block):
    r = _residual(70_000, 4)
    assert correlation_time(r) == pytest.approx(whole_correlation_time(r), rel=1e-9)
    assert long_run_time(r, 25) == pytest.approx(whole_long_run_time(r, 25), rel=1e-9)
    parts = [r[:33_333], r[33_333:]]
    assert long_run_time(parts, 25) == pytest.approx(whole_long_run_time(r, 25), rel=1e-9)
    # the slow wander makes the block-mean ratio the larger one: that branch is covered
    assert long_run_time(r, 25) > correlation_time(r)


def test_short_and_constant_series_as_before():
    assert correlation_time(np.array([1.0, 2.0, np.nan])) == 1.0
    with np.errstate(invalid="ignore"):  # the whole-series form divides 0 by 0
        assert long_run_time(np.ones(100), 4) == whole_long_run_time(np.ones(100), 4) == 1.0
    with pytest.raises(DetectorError, match="too little healthy data.*799 finite"):
        calibrate(np.r_[np.arange(799.0), np.nan], 25)
    with pytest.raises(DetectorError, match="constant"):
        calibrate(np.ones(5000), 25)


def test_a_memory_mapped_series_is_read_and_given_back(tmp_path):
    r = _residual(300_000, 5)
    mapped = open_memmap(tmp_path / "r.npy", mode="w+", dtype=np.float64, shape=r.shape)
    mapped[:] = r
    mapped.flush()
    _same_calibration(calibrate(mapped, 25, 1e-6), whole_calibrate(r, 25, 1e-6))
    np.testing.assert_array_equal(mapped, r)  # read, never written


def test_the_running_pieces_equal_their_whole_series_forms():
    rng = np.random.default_rng(6)
    x = rng.standard_normal(10_000) + 3.0
    cuts = [0, 1, 7, 250, 251, 4000, 9999, 10_000]
    pieces = [x[a:b] for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    moments, lags, sums, means = RunningMoments(), LaggedSums(300), WindowSums(40), BlockMeans(64)
    got_sums = []
    for p in pieces:
        moments.add(p)
        lags.add(p)
        got_sums.append(sums.add(p))
        means.add(p)
    assert moments.n == x.shape[0]
    assert moments.mean == pytest.approx(np.mean(x), rel=1e-13)
    assert moments.var(ddof=1) == pytest.approx(np.var(x, ddof=1), rel=1e-12)
    np.testing.assert_allclose(lags.values(), lagged_products(x, 300), rtol=1e-10)
    np.testing.assert_allclose(
        np.concatenate(got_sums), 40 * moving_mean(x, 40)[39:], rtol=1e-10, atol=1e-10
    )
    whole = x[: 156 * 64].reshape(156, 64).mean(axis=1)
    assert means.moments.n == 156
    assert means.moments.var(ddof=1) == pytest.approx(np.var(whole, ddof=1), rel=1e-12)
    # a series shorter than the lags: as lagged_products of it
    short = LaggedSums(300)
    short.add(x[:5])
    short.add(x[5:9])
    np.testing.assert_allclose(short.values(), lagged_products(x[:9], 300), rtol=1e-12)


def test_finite_blocks_close_gaps_in_order():
    parts = [np.array([1.0, np.nan, 2.0, 3.0]), np.array([np.inf, 4.0]), np.array([], float)]
    got = list(finite_blocks(parts, block=2))
    assert [b.tolist() for b in got] == [[1.0], [2.0, 3.0], [4.0]]
    assert [b.tolist() for b in finite_blocks([1.0, float("nan"), 2.0])] == [[1.0, 2.0]]
    assert list(finite_blocks([])) == []
    with pytest.raises(ValueError, match="1-D"):
        list(finite_blocks(np.ones((3, 2))))


@pytest.mark.parametrize("block", [None, 40])
def test_row_moments_equal_corrcoef_of_the_rows_without_a_gap(block, monkeypatch):
    """The equivalent model's sensor network is designed from these correlations."""
    if block is not None:
        monkeypatch.setattr(streamed, "SERIES_BLOCK", block)  # 10 rows per block of 4 columns
    rng = np.random.default_rng(7)
    X = rng.standard_normal((1001, 6)) @ rng.standard_normal((6, 6)) + 10.0
    X[5, 2] = np.nan
    X[300:320, 4] = np.nan
    X[400, 0] = np.nan  # not a used column: the row counts
    cols = [1, 2, 4, 5]
    got = streamed.row_moments(X, cols)
    sel = X[:, cols]
    ok = np.isfinite(sel).all(axis=1)
    assert got.n == ok.sum() == 1001 - 21
    np.testing.assert_allclose(got.correlation(), np.corrcoef(sel[ok].T), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(got.covariance(), np.cov(sel[ok].T), rtol=1e-12)
    flat = X.copy()
    flat[:, 1] = 2.0
    with np.errstate(invalid="ignore", divide="ignore"):
        expect = np.corrcoef(flat[ok][:, cols].T)
    c = streamed.row_moments(flat, cols).correlation()
    assert np.array_equal(np.isnan(c), np.isnan(expect))  # a constant sensor: NaN, as before


def test_the_statistics_hold_blocks_not_the_series():
    """What a fit on a long window relies on: numpy's allocations during each statistic
    stay a few blocks (a few MB), whatever the length (here a 19 MB series, a 49 MB
    window, both above the bound; computed on the whole, each made several copies)."""
    import tracemalloc

    from analyzer.detectors.ar_model import _column_stats

    rng = np.random.default_rng(8)
    r = rng.standard_normal(2_500_000)
    r[1000:1100] = np.nan
    Y = rng.standard_normal((400_000, 16))
    cases = {
        "calibrate": lambda: calibrate(r, 25, 1e-6),
        "correlation_time": lambda: correlation_time(r),
        "long_run_time": lambda: long_run_time([r[:1_500_000], r[1_500_000:]], 25),
        "column stats": lambda: _column_stats(Y),
        "row moments": lambda: streamed.row_moments(Y, [0, 3, 5, 15]),
    }
    for name, run in cases.items():
        tracemalloc.start()
        try:
            run()
            peak = tracemalloc.get_traced_memory()[1]
        finally:
            tracemalloc.stop()
        assert peak < 16 * 2**20, f"{name}: {peak / 2**20:.1f} MB"

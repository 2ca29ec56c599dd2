"""Windowed tests agree with the scalar tests applied window by window (to 1e-9), skip
windows with gaps, and find the onset of a fault."""

from __future__ import annotations

import numpy as np
import pytest

import analyzer.stats as st
from analyzer.errors import DetectorError
from analyzer.stats.windowed import WindowedTests

TOL = 1e-9
"""Windowed and scalar statistics agree to this, relative and absolute."""


def residual(n: int, seed: int) -> np.ndarray:
    """White noise with what a long residual carries: a slow drift, a 10-sigma offset
    stretch, gross errors, a stuck (constant) stretch, a noisy stretch and NaN gaps."""
    rng = np.random.default_rng(seed)
    z = rng.normal(size=n) + np.linspace(0.0, 3.0, n)
    z[n // 5 : n // 5 + 700] += 10.0
    z[rng.choice(n, n // 200, replace=False)] += 6.0
    z[n // 2 : n // 2 + 450] = 0.25
    z[3 * n // 5 : 3 * n // 5 + 800] *= 1.6
    z[[123, 4321, 4322]] = np.nan
    return z


def assert_matches_scalar(result: WindowedTests, z: np.ndarray) -> None:
    checked = 0
    for i, start in enumerate(result.start):
        segment = z[start : start + result.window]
        if not np.isfinite(segment).all():
            assert not result.valid[i]
            continue
        assert result.valid[i]
        scalar = st.run_all(segment, lags=result.lags, k=result.k, case=result.case)
        for name, expected in scalar.items():
            stats = getattr(result, name)
            np.testing.assert_allclose(
                stats.statistic[i], expected.statistic, rtol=TOL, atol=TOL, err_msg=name
            )
            assert stats.reject[i] == expected.reject, (name, i)
            assert stats.critical == pytest.approx(expected.critical, rel=1e-12)
            if expected.pvalue is None or name in ("anderson_darling", "cramer_von_mises"):
                # the windows count decisions: no p-value for the normality tests there
                assert stats.pvalue is None
            else:
                assert stats.pvalue is not None
                np.testing.assert_allclose(
                    stats.pvalue[i], expected.pvalue, rtol=TOL, atol=TOL, err_msg=name
                )
        white = scalar["whiteness"]
        assert isinstance(white, st.WhitenessResult)
        assert result.acf is not None
        np.testing.assert_allclose(result.acf[i], white.acf, rtol=TOL, atol=TOL)
        np.testing.assert_allclose(result.band_fraction[i], white.band_fraction, rtol=TOL, atol=TOL)
        assert result.outliers[i] == scalar["shewhart"].as_dict()["count"]
        np.testing.assert_allclose(result.means[i], segment.mean(), rtol=TOL, atol=TOL)
        checked += 1
    assert checked >= 0.8 * result.n_windows  # only windows over a NaN are skipped


@pytest.mark.parametrize(
    ("window", "step", "case", "batch_values"),
    [
        (250, None, 1, 1 << 16),  # non-overlapping, one batch
        (250, 100, 2, 1_000),  # overlapping, many batches
        (120, 400, 1, 2_000),  # gaps between windows
        (500, 37, 2, 1),  # one window per batch
    ],
)
def test_windowed_equals_scalar_per_window(
    window: int, step: int | None, case: int, batch_values: int
) -> None:
    z = residual(10_000, seed=window)
    result = st.windowed_tests(z, window, step, case=case, keep_acf=True, batch_values=batch_values)
    expected_step = window if step is None else step
    np.testing.assert_array_equal(result.start, np.arange(0, 10_000 - window + 1, expected_step))
    assert result.step == expected_step
    assert_matches_scalar(result, z)


def test_other_lags_and_limit() -> None:
    z = residual(6_000, seed=9)
    result = st.windowed_tests(z, 300, 150, lags=5, k=2.5, keep_acf=True)
    assert result.acf is not None and result.acf.shape == (result.n_windows, 5)
    assert_matches_scalar(result, z)


def test_batches_do_not_change_the_result() -> None:
    z = residual(8_000, seed=3)
    one = st.windowed_tests(z, 400, 250, batch_values=1 << 20)
    many = st.windowed_tests(z, 400, 250, batch_values=900)
    for name in WindowedTests.TESTS:
        a, b = getattr(one, name), getattr(many, name)
        np.testing.assert_allclose(a.statistic, b.statistic, rtol=1e-10, atol=1e-12)
        np.testing.assert_array_equal(a.reject, b.reject)


def test_windows_with_gaps_are_not_tested() -> None:
    z = np.random.default_rng(0).normal(size=1000)
    z[250] = np.nan
    z[990] = np.inf
    result = st.windowed_tests(z, 100)
    assert result.valid.tolist() == [True, True, False] + [True] * 6 + [False]
    for stats in result.tests().values():
        assert np.isnan(stats.statistic[~result.valid]).all()
        assert not stats.reject[~result.valid].any()
        assert np.isfinite(stats.statistic[result.valid]).all()


def test_trailing_partial_window_is_dropped() -> None:
    result = st.windowed_tests(np.zeros(1099), 100, 50)
    assert result.n_windows == 20
    assert result.start[-1] == 950


def test_fault_onset_shows_in_the_windows() -> None:
    # 50 Hz interference (1 kHz sampling) appears at sample 30 000.
    rng = np.random.default_rng(4)
    t = np.arange(60_000) / 1000.0
    z = rng.normal(size=60_000)
    z[30_000:] += 0.8 * np.sin(2 * np.pi * 50 * t[30_000:])
    z[30_000:] /= np.sqrt(1.32)
    result = st.windowed_tests(z, 1000)
    before, after = result.start < 30_000, result.start >= 30_000
    assert result.whiteness.reject[after].all()
    assert result.whiteness.reject[before].sum() <= 5
    assert not result.covariance.reject[after].all()  # the variance was kept at 1


def test_result_is_read_only() -> None:
    result = st.windowed_tests(np.random.default_rng(1).normal(size=500), 100)
    with pytest.raises(ValueError, match="read-only"):
        result.mean.statistic[0] = 0.0
    assert result.acf is None


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"z": np.zeros((100, 2)), "window": 50}, r"1-D standardized residual .*\(100, 2\)"),
        ({"z": np.zeros(100), "window": 20, "lags": 20}, r"expected window >= 21, got 20"),
        ({"z": np.zeros(100), "window": 7, "lags": 2}, r"expected window >= 8, got 7"),
        ({"z": np.zeros(100), "window": 200}, r"z has 100 samples, fewer than one window of 200"),
        ({"z": np.zeros(100), "window": 50, "step": 0}, r"expected step >= 1, got 0"),
        ({"z": np.zeros(100), "window": 50, "k": 0.0}, r"expected a finite k > 0, got 0.0"),
        ({"z": np.zeros(100), "window": 50, "case": 0}, r"expected case 1 .*, got 0"),
        ({"z": np.zeros(100), "window": 50, "lags": 0}, r"expected lags >= 1, got 0"),
        ({"z": np.zeros(100), "window": 50.0}, r"expected an integer window, got 50.0"),
        ({"z": ["x"] * 100, "window": 50}, r"expected numeric samples for z"),
    ],
)
def test_bad_input_raises(kwargs: dict[str, object], match: str) -> None:
    with pytest.raises(DetectorError, match=match):
        st.windowed_tests(**kwargs)  # type: ignore[arg-type]

"""The mean's verdict on a stretch that is not white (ux54 item 5): the mean test
assumes whiteness (seed 003 tests it first), so where whiteness rejects the evidence
judges the mean against the stretch's long-run variance (Newey-West) and a correctly
found gain is no longer marked ``tests_agree: false``."""

from __future__ import annotations

import numpy as np
import pytest
import statsmodels.api as sm
from statsmodels.stats.sandwich_covariance import cov_hac

from analyzer.diagnosis.evidence import _tests, consistent_types
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive


def _coloured(seed: int, n: int = 2000) -> np.ndarray:
    """A floor's simulated response in units of its deviation: strongly coloured."""
    _, y, _ = simulate_building(4, n / 100.0 + 1.0, 100.0, seed=seed)
    x = y[:n, 3] - y[:n, 3].mean()
    return x / x.std()


@pytest.mark.parametrize("lags", [0, 5, 20])
def test_long_run_variance_is_statsmodels_hac(lags: int) -> None:
    from analyzer.stats.moments import long_run_variance  # new here (fails on 733b512)

    x = _coloured(1) + 0.3
    fit = sm.OLS(x, np.ones((x.shape[0], 1))).fit()
    hac = float(cov_hac(fit, nlags=lags, use_correction=False)[0, 0])
    assert long_run_variance(x, lags) / x.shape[0] == pytest.approx(hac, rel=1e-10)
    if lags == 0:  # no lag: the (biased) variance
        assert long_run_variance(x, 0) == pytest.approx(float(np.var(x)), rel=1e-12)


def test_long_run_mean_test_on_white_noise_is_the_plain_test() -> None:
    from analyzer.stats.moments import long_run_mean_test

    x = np.random.default_rng(3).standard_normal(4000) + 0.04
    plain = np.sqrt(x.shape[0]) * abs(x.mean()) / x.std()
    t = long_run_mean_test(x, 20)
    assert t.statistic == pytest.approx(plain, rel=0.05)
    assert (
        t.critical == pytest.approx(1.96, abs=1e-4)
        and t.reject == (t.statistic > 1.96)
        and t.lags == 20
    )


def test_a_coloured_stretch_with_an_offset_still_points_to_an_offset() -> None:
    """A coloured healthy part does not hide an offset of half its deviation."""
    for seed in range(3):
        rng = np.random.default_rng(seed)
        after = _tests(0.5 * _coloured(seed) + rng.standard_normal(2000) + 0.5)
        assert after is not None and after["whiteness"]["reject"]
        assert after["mean_long_run"]["reject"]
        assert "additive" in consistent_types(after)


@pytest.mark.parametrize("gain", [1.3, 0.7])
def test_a_gain_found_right_has_tests_that_agree(tmp_path, gain: float) -> None:
    """3 floors, 2 sensors each, a gain on s2 from 180 s (ux54's 3x2 seed 501): its
    stretch after the onset is far from white (the gain multiplies the structure's
    response) and its plain mean test rejected, so the tests pointed to an offset and
    the confidence was cut to 0.8x; the long-run variance holds that mean to its t of
    about 1, and the tests point to the gain."""
    t, y, names = simulate_building(3, 300.0, 100.0, seed=501, sensors_per_floor=2)
    y[:, 2] = inject_fault(y[:, 2], 100.0, "multiplicative", 180.0, gain)
    path = tmp_path / "gain.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, i] for i, n in enumerate(names)}
    )
    work = tmp_path / "work"
    work.mkdir()
    (f,) = analyze([str(path)], RunOptions(), work).findings
    assert (f.channel, f.type.value) == ("s2", "multiplicative")
    assert f.evidence["tests_agree"] is True  # (first: the base lacks mean_long_run)
    after = f.evidence["tests"][f.detector]["after"]
    assert after["whiteness"]["reject"] and after["mean"]["reject"]
    assert not after["mean_long_run"]["reject"]


def test_a_stretch_of_zeros_is_no_offset() -> None:
    """No spread and a zero mean: t = 0 (it read inf and rejected, a review); a constant
    non-zero stretch still rejects."""
    from analyzer.stats.moments import long_run_mean_test

    assert long_run_mean_test(np.zeros(50), 5).statistic == 0.0
    assert not long_run_mean_test(np.zeros(50), 5).reject
    assert long_run_mean_test(np.full(50, 2.0), 5).reject

"""JSON-friendly evidence: ``test_segment`` and ``summarize`` give plain types that
``json.dumps(..., allow_nan=False)`` accepts, for findings.json ``evidence.tests``."""

from __future__ import annotations

import json

import numpy as np
import pytest

import analyzer.stats as st
from analyzer.errors import DetectorError

KEYS = {"statistic", "critical", "reject", "pvalue", "n"}


def plain(value: object) -> bool:
    """True when ``value`` is made of JSON's own Python types only."""
    if isinstance(value, dict):
        return all(isinstance(k, str) and plain(v) for k, v in value.items())
    if isinstance(value, list):
        return all(plain(v) for v in value)
    return value is None or type(value) in (bool, int, float, str)


def test_segment_runs_every_test() -> None:
    z = np.random.default_rng(0).normal(size=2000)
    evidence = st.test_segment(z)
    assert list(evidence) == [
        "shewhart",
        "anderson_darling",
        "cramer_von_mises",
        "whiteness",
        "mean",
        "covariance",
    ]
    for name, entry in evidence.items():
        assert entry.keys() >= KEYS, name
        assert entry["n"] == 2000
    assert evidence["anderson_darling"]["critical"] == 2.492
    assert evidence["anderson_darling"]["statistic"] == pytest.approx(
        st.anderson_darling(z).statistic
    )
    assert evidence["covariance"]["critical_low"] is not None
    assert plain(evidence)
    json.dumps(evidence, allow_nan=False)


def test_segment_case2_and_a_faulty_segment() -> None:
    rng = np.random.default_rng(1)
    z = rng.exponential(size=1000) - 1.0 + 0.5
    evidence = st.test_segment(z, case=2, lags=10, k=2.5)
    assert evidence["anderson_darling"]["case"] == 2
    assert evidence["anderson_darling"]["critical"] == 0.787
    assert evidence["anderson_darling"]["reject"] is True
    assert evidence["mean"]["reject"] is True
    assert evidence["whiteness"]["lags"] == 10
    assert evidence["shewhart"]["k"] == 2.5


def test_stuck_segment_gives_null_not_nan() -> None:
    evidence = st.test_segment(np.full(500, 0.3), case=2)
    assert evidence["anderson_darling"]["statistic"] is None  # infinite: not Gaussian
    assert evidence["anderson_darling"]["reject"] is True
    assert evidence["whiteness"]["statistic"] is None  # undefined on a constant
    assert evidence["whiteness"]["reject"] is False
    assert evidence["covariance"]["reject"] is True  # 45 against chi-square(500)
    json.dumps(evidence, allow_nan=False)


def test_summarize_named_results() -> None:
    z = np.random.default_rng(2).normal(size=300)
    results = {"mean": st.mean_test(z), "whiteness": st.whiteness(z, 5)}
    summary = st.summarize(results)
    assert summary == {name: r.as_dict() for name, r in results.items()}
    assert len(summary["whiteness"]["acf"]) == 5  # type: ignore[arg-type]


def test_summarize_windowed_counts_rejections() -> None:
    z = np.random.default_rng(3).normal(size=20_000)
    z[15_000:] *= 1.5
    z[555] = np.nan
    result = st.windowed_tests(z, 500)
    summary = st.summarize(result)
    assert summary["windows"] == {
        "count": 40,
        "valid": 39,
        "window": 500,
        "step": 500,
        "lags": 20,
        "k": 3.0,
        "case": 1,
    }
    for name in result.TESTS:
        stats = getattr(result, name)
        assert summary[name]["rejected"] == int(stats.reject.sum())
        assert summary[name]["windows"] == 39
    assert result.covariance.reject[30:].all()  # the last 10 windows are noisy
    assert summary["covariance"]["critical_low"] is not None
    assert plain(summary)
    json.dumps(summary, allow_nan=False)


def test_segment_bad_input_raises() -> None:
    with pytest.raises(DetectorError, match=r"at least 8 finite samples, got 5"):
        st.test_segment(np.zeros(5), lags=2)
    with pytest.raises(DetectorError, match=r"more than lags=20 finite samples, got 15"):
        st.test_segment(np.zeros(15), lags=20)
    with pytest.raises(DetectorError, match=r"all 9 values of z are NaN"):
        st.test_segment(np.full(9, np.nan))


@pytest.mark.parametrize("window", [100, 200, 1000])
def test_windowed_shewhart_expects_its_exact_level(window: int) -> None:
    """Audit: the windowed summary compared the Shewhart chart's share of rejecting
    windows with 5 %, which its binomial test of a count cannot reach (a healthy
    residual: 3.1 % at 100 samples, 1.5 % at 200)."""
    from scipy.stats import binom, norm

    z = np.random.default_rng(window).standard_normal(window * 3000)
    summary = st.summarize(st.windowed_tests(z, window))
    p0 = 2.0 * norm.sf(3.0)
    counts = np.arange(window + 1)
    first = counts[binom.sf(counts - 1, window, p0) < 0.05][0]
    level = binom.sf(first - 1, window, p0)
    assert summary["shewhart"]["expected"] == pytest.approx(level, rel=1e-9)
    assert level < 0.035
    assert summary["shewhart"]["fraction"] == pytest.approx(level, abs=0.01)
    assert summary["whiteness"]["expected"] == 0.05

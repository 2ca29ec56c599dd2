"""p-values of the Anderson-Darling and Cramer-von Mises tests (ux54 item 10): they were
null; each case's published approximation of its null law now gives one, checked
against the tabulated 5 % points, scipy and statsmodels."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from statsmodels.stats.diagnostic import normal_ad

from analyzer.stats import normality, test_segment
from analyzer.stats.normality import anderson_darling, cramer_von_mises


@pytest.mark.parametrize(("a2", "p"), [(1.933, 0.10), (2.492, 0.05), (3.070, 0.025), (3.857, 0.01)])
def test_case1_anderson_darling_at_stephens_points(a2: float, p: float) -> None:
    """Stephens' (1974) upper points of A^2 for a known law, large N."""
    assert 1.0 - normality._marsaglia_cdf(a2, 2000) == pytest.approx(p, abs=0.001)


def test_case2_points_of_both_tests() -> None:
    """D'Agostino and Stephens' 5 % points: A^2* 0.752, W^2* 0.126."""
    n = 10**6
    assert normality._ad_case2_pvalue(0.752, n) == pytest.approx(0.05, abs=0.002)
    assert normality._cvm_case2_pvalue(0.126, n) == pytest.approx(0.05, abs=0.002)


@pytest.mark.parametrize("shift", [0.0, 0.06, 0.12])
def test_against_scipy_and_statsmodels(shift: float) -> None:
    x = np.random.default_rng(1).standard_normal(500) + shift
    assert cramer_von_mises(x, 1).pvalue == pytest.approx(
        stats.cramervonmises(x, "norm").pvalue, abs=0.002
    )
    assert anderson_darling(x, 2).pvalue == pytest.approx(float(normal_ad(x)[1]), rel=1e-9)


@pytest.mark.parametrize("case", [1, 2])
def test_pvalues_are_uniform_on_gaussian_samples(case: int) -> None:
    """Under the null about 5 % of p-values fall below 0.05 (1 000 samples of 100)."""
    rng = np.random.default_rng(7)
    for test in (anderson_darling, cramer_von_mises):
        p = np.array([test(rng.standard_normal(100), case).pvalue for _ in range(1000)])
        assert 0.03 <= float(np.mean(p < 0.05)) <= 0.07
        assert 0.45 <= float(np.mean(p < 0.5)) <= 0.55


def test_the_evidence_carries_them() -> None:
    out = test_segment(np.random.default_rng(2).standard_normal(800))
    for name in ("anderson_darling", "cramer_von_mises"):
        p = out[name]["pvalue"]
        assert isinstance(p, float) and 0.0 <= p <= 1.0
        assert (p < 0.05) == out[name]["reject"] or abs(
            out[name]["statistic"] - out[name]["critical"]
        ) < 0.05


def test_the_report_cell_shows_the_pvalue() -> None:
    from analyzer.report.view_tables import _cell

    t = {"statistic": 1.0, "critical": 2.492, "reject": False, "pvalue": 0.356, "n": 2000}
    assert _cell(t, "anderson_darling").critical == "2.492, p 0.36"


@pytest.mark.parametrize("w2", [1.2, 3.0, 50.0, 2e3, 1e4, 1e6])
def test_the_cramer_von_mises_tail_never_climbs_back(w2: float) -> None:
    """Far in the tail the asymptotic series lost its sum and ``1 - cdf`` rose back to
    0.01-0.23 (a review): the p-value falls with the statistic, to 0."""
    p = 1.0 - normality._cvm_asymptotic_cdf(w2)
    assert 0.0 <= p <= 1.0 - normality._cvm_asymptotic_cdf(1.168) + 1e-12
    assert p < 1e-3

"""The evidence's whitening (``analyzer.diagnosis.evidence``): the detectors' residuals
are coloured even when healthy, and the seed's innovation tests failed on every healthy
stretch before a fault's onset; the tests now run on the one-step error of an AR model
of the training window's residual."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter
from statsmodels.regression.linear_model import yule_walker

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis import evidence
from analyzer.diagnosis.evidence import Whitening, attach_evidence, fit_whitening
from analyzer.diagnosis.merge import Finding
from analyzer.types import FaultType


def _ar(n: int, coef: list[float], seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return lfilter([1.0], np.concatenate(([1.0], -np.asarray(coef))), rng.standard_normal(n))


@pytest.mark.parametrize("order", [1, 2, 5])
def test_the_fit_is_statsmodels_yule_walker(order):
    """Levinson-Durbin on the biased autocovariances: statsmodels' ``yule_walker``
    (method "mle": the same estimator, solved as a Toeplitz system), to rounding."""
    x = _ar(5000, [0.6, -0.3, 0.1], seed=order)
    w = fit_whitening(x, order=order)
    rho, sigma = yule_walker(x, order=order, method="mle", result_object=False)
    assert w is not None and w.order == order
    np.testing.assert_allclose(w.coefficients, rho, rtol=1e-9, atol=1e-12)
    assert w.scale == pytest.approx(sigma, rel=1e-9)


def test_aic_finds_the_order_of_an_ar_process_and_whitens_it():
    x = _ar(20_000, [1.2, -0.5], seed=3)
    w = fit_whitening(x)
    assert w is not None and 2 <= w.order <= 4
    np.testing.assert_allclose(w.coefficients[:2], [1.2, -0.5], atol=0.03)
    e = w.apply(x, 0)
    assert np.isnan(e[: w.order]).all()  # the filter reaches before the data there
    e = e[w.order :]
    assert np.std(e) == pytest.approx(1.0, abs=0.02)
    lag1 = float(np.corrcoef(e[1:], e[:-1])[0, 1])
    assert abs(lag1) < 0.02  # was 0.8
    # white noise needs no model
    assert fit_whitening(np.random.default_rng(1).standard_normal(20_000)).order <= 2


def test_a_gap_spoils_only_the_samples_whose_filter_window_holds_it():
    w = Whitening((0.5, -0.2), 2.0)
    z = np.arange(20.0)
    z[10] = np.nan
    e = w.apply(z, 0)
    direct = np.full(20, np.nan)
    for t in range(2, 20):
        direct[t] = (z[t] - 0.5 * z[t - 1] + 0.2 * z[t - 2]) / 2.0
    bad = np.isnan(direct)
    assert bad.tolist() == np.isnan(e).tolist()
    assert np.flatnonzero(bad).tolist() == [0, 1, 10, 11, 12]
    np.testing.assert_allclose(e[~bad], direct[~bad])
    assert Whitening.from_dict(w.as_dict()) == w
    assert Whitening.from_dict({"order": 2}) is None and Whitening.from_dict(None) is None


def _coloured_result(offset: float, seed: int = 0) -> tuple[DetectorResult, int]:
    """A detector's residual as coloured as a leave-one-out estimate's (AR(1) 0.9), with
    ``offset`` healthy deviations added from its onset."""
    n, onset = 60_000, 40_000
    r = _ar(n, [0.9], seed=seed)
    std = float(np.std(r[:10_000]))
    r[onset:] += offset * std
    res = DetectorResult(
        "d", ("a",), {}, [], {"a": r}, sigma={"a": std}, thresholds={"a": {"std": std}}
    )
    return res, onset


def _finding(onset: int, rate: float) -> Finding:
    return Finding(
        "a", FaultType.ADDITIVE, onset / rate, None, {"offset": 1.0}, 0.9, "d", {"detectors": ["d"]}
    )


def test_a_coloured_healthy_stretch_passes_and_an_offset_breaks_the_mean():
    rate, train = 100.0, (0, 12_000)
    res, onset = _coloured_result(0.5)
    f = _finding(onset, rate)
    attach_evidence([f], [res], rate, train)
    t = f.evidence["tests"]["d"]
    assert t["whitening"]["order"] >= 1
    assert not t["before"]["whiteness"]["reject"]
    assert not t["before"]["mean"]["reject"]
    assert t["after"]["mean"]["reject"]
    assert "additive" in t["consistent_with"] and f.evidence["tests_agree"]
    # unwhitened (--model: no healthy window of the record's own), the same healthy
    # stretch fails whiteness
    g = _finding(onset, rate)
    attach_evidence([g], [res], rate, train, whiten=False)
    u = g.evidence["tests"]["d"]
    assert "whitening" not in u and u["before"]["whiteness"]["reject"]


def test_the_before_stretch_starts_after_the_filters_settle():
    """The first quarter of the training window (the filters' start) is never tested."""
    rate, train = 100.0, (0, 8_000)
    res, _ = _coloured_result(0.0)
    f = _finding(1_500, rate)  # onset inside the window's first quarter + a bit
    attach_evidence([f], [res], rate, train)
    t = f.evidence["tests"]["d"]
    assert t["before_span_s"] == [1_500 / rate, 1_500 / rate]  # nothing left before it
    assert t["before"] is None
    g = _finding(2_400, rate)
    attach_evidence([g], [res], rate, train)
    assert g.evidence["tests"]["d"]["before_span_s"][0] == evidence.settled(train) / rate


def test_a_gain_s_larger_noise_is_not_read_as_an_offset():
    """The mean test holds the mean against the healthy deviation: 2 000 samples of a
    gain of 1.5 whose mean wandered 0.05 moved it past 1.96 / sqrt(N) and the tests
    pointed to an offset; against the stretch's own spread they point to the gain. An
    offset leaves the spread as it was and still points to an offset."""
    from analyzer.stats import test_segment

    rng = np.random.default_rng(5)
    noise = rng.standard_normal(2000)
    gain = test_segment(1.5 * (noise - noise.mean()) + 0.05)
    assert gain["mean"]["reject"] and gain["covariance"]["reject"]
    kinds = evidence.consistent_types(gain)
    assert "multiplicative" in kinds and "additive" not in kinds
    offset = test_segment(noise - noise.mean() + 0.5)
    assert offset["mean"]["reject"] and offset["covariance"]["reject"]
    assert evidence.consistent_types(offset)[:2] == ["additive", "drift"]
    both = test_segment(1.5 * (noise - noise.mean()) + 0.5)  # a gain and an offset
    assert evidence.consistent_types(both)[:2] == ["additive", "drift"]

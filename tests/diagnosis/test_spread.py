"""95 % intervals of a fault's size and onset (:mod:`analyzer.diagnosis.spread`): the
size's standard error is the fit's own HAC (Newey-West) one, the same as statsmodels' OLS
``cov_type="HAC"`` on the same samples; a drift's traced onset has the delta method's;
a change point's onset the likelihood profile's; an onset that is a bound has none, and
says why; the intervals hold their estimate and shrink as the fault's stretch grows."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import statsmodels.api as sm
from scipy.signal import lfilter

from analyzer.detectors.base import Event
from analyzer.diagnosis import Finding, classify, correlation_time
from analyzer.diagnosis.changes import calibrate, detect
from analyzer.diagnosis.spread import Z_95, event_intervals
from analyzer.findings import finding_intervals
from analyzer.types import FaultType

RATE = 100.0


def coloured(n: int, seed: int, phi: float = 0.6, scale: float = 0.3) -> np.ndarray:
    """AR(1) noise: a residual whose samples are correlated, as a filter's are."""
    rng = np.random.default_rng(seed)
    return lfilter([1.0], [1.0, -phi], rng.normal(scale=scale, size=n))


def hac(y: np.ndarray, x: np.ndarray, lags: int) -> object:
    return sm.OLS(y, x).fit(cov_type="HAC", cov_kwds={"maxlags": lags, "use_correction": False})


def test_offset_error_is_statsmodels_hac_of_the_mean():
    noise = coloured(3000, 1)
    f = 0.8 + noise
    c = classify(f, None, float(noise.std()), RATE, correlation_time(noise))
    assert c.type is FaultType.ADDITIVE and c.spread is not None
    ref = hac(f, np.ones((f.shape[0], 1)), c.spread.lags)
    assert c.magnitude["offset"] == pytest.approx(float(ref.params[0]), rel=1e-12)
    assert c.spread.se["offset"] == pytest.approx(float(ref.bse[0]), rel=1e-8)
    # the correlation counts: the white-noise error would be far smaller
    assert c.spread.se["offset"] > 1.5 * float(f.std()) / np.sqrt(f.shape[0])


def test_drift_rate_and_onset_errors_are_statsmodels_hac_and_the_delta_method():
    n = 4000
    noise = coloured(n, 2)
    tau = np.arange(n) / RATE
    f = 0.2 * (tau + 1.5) + noise  # zero 1.5 s before the detected onset
    c = classify(f, None, float(noise.std()), RATE, correlation_time(noise))
    assert c.type is FaultType.DRIFT and c.spread is not None
    assert c.onset_shift_s == pytest.approx(-1.5, abs=0.5)
    ref = hac(f, np.column_stack((np.ones(n), tau)), c.spread.lags)
    assert c.magnitude["rate_per_s"] == pytest.approx(float(ref.params[1]), rel=1e-10)
    assert c.spread.se["rate_per_s"] == pytest.approx(float(ref.bse[1]), rel=1e-8)
    # the onset -c / b: the delta method on statsmodels' covariance of (c, b)
    c0, b = (float(v) for v in ref.params)
    grad = np.array([-1.0 / b, c0 / b**2])
    sd = float(np.sqrt(grad @ ref.cov_params() @ grad))
    assert c.spread.onset_sd_s == pytest.approx(sd, rel=1e-6)


def test_gain_interval_covers_the_true_gain_about_95_percent():
    """The scaled gain's sandwich and delta method, checked by simulation: over 200 white
    records the interval holds the true gain 0.6 in 93-99 % of them (binomial spread
    about 95 %: +-3 %)."""
    n = 1500
    t = np.arange(n) / RATE
    ref = 2.0 * np.sin(2 * np.pi * 1.3 * t) + np.sin(2 * np.pi * 3.1 * t + 1.0)
    held = 0
    for seed in range(200):
        e = np.random.default_rng(seed).normal(scale=0.3, size=n)
        c = classify(0.6 * (ref + e) - ref, ref, 0.3, RATE)
        assert c.type is FaultType.MULTIPLICATIVE and c.spread is not None
        half = Z_95 * c.spread.se["gain"]
        held += abs(c.magnitude["gain"] - 0.6) <= half
    assert 0.9 <= held / 200 <= 0.99


@pytest.mark.parametrize("kind", ["offset", "drift", "gain"])
def test_interval_holds_its_estimate_and_shrinks_with_a_longer_stretch(kind):
    widths = []
    for n in (1000, 8000):
        noise = coloured(n, 3)
        tau = np.arange(n) / RATE
        ref = 2.0 * np.sin(2 * np.pi * 1.3 * tau)
        f = {"offset": 0.8 + noise, "drift": 0.05 * tau + noise, "gain": 0.5 * ref + noise}[kind]
        c = classify(f, ref, float(noise.std()), RATE, correlation_time(noise))
        key = next(iter(c.magnitude))
        ev = event_intervals(c, None, 10.0, {}, RATE)
        lo, hi = ev["magnitude"][key]
        assert lo < c.magnitude[key] < hi
        widths.append(hi - lo)
    assert widths[1] < 0.6 * widths[0]


def _stepped(step: float) -> tuple[object, int]:
    """The first interval :func:`detect` finds on white noise that steps by ``step`` at
    sample 15 000 (calibrated on the first 10 000)."""
    r = np.random.default_rng(4).normal(size=30_000)
    r[15_000:] += step
    cal = calibrate(r[:10_000], 25)
    return detect(r, cal, search_start=10_000)[0], 15_000


def test_change_point_onset_range_holds_the_onset_and_narrows_with_a_larger_step():
    spans = []
    for step in (0.6, 3.0):
        iv, true = _stepped(step)
        assert iv.onset_range is not None
        lo, hi = iv.onset_range
        assert lo <= iv.onset <= hi and lo <= true <= hi
        spans.append(hi - lo)
    assert spans[1] < spans[0]


def _finding(
    evidence: dict,
    extra: dict,
    magnitude_of_finding: dict | None = None,
    level_variance: float | None = 1e-4,
) -> Finding:
    noise = coloured(2000, 5)
    c = classify(0.8 + noise, None, float(noise.std()), RATE, correlation_time(noise))
    iv = event_intervals(c, (990, 1010), 10.0, extra, RATE, level_variance)
    ev = Event("s1", 10.0, None, c.type, c.magnitude, 0.9, "det", {}, iv)
    mag = dict(c.magnitude) if magnitude_of_finding is None else magnitude_of_finding
    return Finding("s1", c.type, 10.0, None, mag, 0.9, "det", evidence, [ev])


def test_finding_intervals_hold_the_size_and_onset():
    f = _finding({}, {})
    out = finding_intervals(f)
    lo, hi = out["magnitude_interval"]["offset"]
    assert out["magnitude_interval"]["level"] == 0.95
    assert lo < f.magnitude["offset"] < hi
    # one sample period before the profile's first onset (sample 990): the fault began
    # after the last sample that may be healthy
    assert out["onset_interval_s"] == [9.89, 10.1]
    assert "interval_notes" not in out


def test_an_onset_on_one_sample_has_an_interval_one_sample_wide():
    """A profile that pins the first faulty sample to ``k`` ([k, k]) gives the interval
    from the sample before it: never zero width."""
    noise = coloured(2000, 5)
    c = classify(0.8 + noise, None, float(noise.std()), RATE, correlation_time(noise))
    lo, hi = event_intervals(c, (1600, 1600), 16.0, {}, RATE, 1e-4)["onset_s"]
    assert hi == 16.0 and lo == pytest.approx(15.99) and hi - lo == pytest.approx(1 / RATE)


def test_a_gains_size_is_noise_only_and_its_onset_has_no_interval():
    """A gain's interval held the true gain in 68-75 % of simulated records: it keeps its
    numbers but says it counts the fit's noise only; its onset (a mean-and-spread
    change-point search, not a gain's model) has none, and says why."""
    n = 3000
    t = np.arange(n) / RATE
    ref = 2.0 * np.sin(2 * np.pi * 1.3 * t)
    e = np.random.default_rng(2).normal(scale=0.3, size=n)
    c = classify(0.6 * (ref + e) - ref, ref, 0.3, RATE)
    assert c.type is FaultType.MULTIPLICATIVE
    iv = event_intervals(c, (990, 1010), 10.0, {}, RATE, 1e-4)
    ev = Event("s1", 10.0, None, c.type, c.magnitude, 0.9, "det", {}, iv)
    out = finding_intervals(
        Finding("s1", c.type, 10.0, None, dict(c.magnitude), 0.9, "det", {}, [ev])
    )
    lo, hi = out["magnitude_interval"]["gain"]
    assert lo < c.magnitude["gain"] < hi
    assert "noise only" in out["interval_notes"]["magnitude"]
    assert "68-75 %" in out["interval_notes"]["magnitude"]
    assert out["onset_interval_s"] is None
    assert "not a gain" in out["interval_notes"]["onset"]


def test_a_model_without_its_sample_count_says_its_size_interval_is_narrower():
    """A model saved before the calibration kept its training sample count has no
    variance of the healthy level: the size's interval leaves that error out, and says
    so (with a known count, no note)."""
    r = np.random.default_rng(4).normal(size=12_000)
    cal = calibrate(r[:10_000], 25)
    assert cal.mean_variance() is not None
    old = dataclasses.replace(cal, samples=0)
    assert old.mean_variance() is None
    full = finding_intervals(_finding({}, {}, level_variance=cal.mean_variance()))
    part = finding_intervals(_finding({}, {}, level_variance=old.mean_variance()))
    assert "interval_notes" not in full
    assert "older version" in part["interval_notes"]["magnitude"]
    (flo, fhi), (plo, phi) = (
        full["magnitude_interval"]["offset"],
        part["magnitude_interval"]["offset"],
    )
    assert phi - plo < fhi - flo


def test_bound_onset_has_no_interval_and_says_why():
    out = finding_intervals(_finding({"onset_at_or_before": True}, {}))
    assert out["onset_interval_s"] is None
    assert "bound" in out["interval_notes"]["onset"]
    assert out["magnitude_interval"] is not None
    traced = finding_intervals(_finding({}, {"starts_in_training": True}))
    assert traced["onset_interval_s"] is None
    assert "healthy window" in traced["interval_notes"]["onset"]


def test_a_size_from_another_fit_shows_no_interval():
    out = finding_intervals(_finding({}, {}, {"offset": 123.0}))
    assert out["magnitude_interval"] is None and out["onset_interval_s"] is None
    assert "no interval" in out["interval_notes"]["magnitude"]


@pytest.mark.parametrize("gain", [0.6, 1.5])
def test_the_healthy_levels_share_is_the_sizes_derivative(gain):
    """The size is measured from the training residual's mean (``shift``), an estimate
    whose error the interval adds by the delta method: the slope it uses is the
    estimate's own derivative (a finite difference of classify)."""
    n = 3000
    t = np.arange(n) / RATE
    ref = 2.0 * np.sin(2 * np.pi * 1.3 * t) + 0.5
    e = np.random.default_rng(1).normal(scale=0.3, size=n)
    f = gain * (ref + e) - ref
    c0, c1 = classify(f, ref, 0.3, RATE), classify(f, ref, 0.3, RATE, shift=1e-5)
    assert c0.spread is not None
    moved = (c1.magnitude["gain"] - c0.magnitude["gain"]) / 1e-5
    assert c0.spread.level_slope["gain"] == pytest.approx(moved, rel=1e-3)
    drift = 0.2 * (t + 1.5) + e
    d0, d1 = classify(drift, None, 0.3, RATE), classify(drift, None, 0.3, RATE, shift=1e-5)
    assert d0.spread is not None
    onset_moved = (d1.onset_shift_s - d0.onset_shift_s) / 1e-5
    assert d0.spread.onset_level_slope == pytest.approx(onset_moved, rel=1e-4)
    # with the level's variance the offset's error grows, and its interval with it
    wide = d0.spread.with_level(0.01)
    assert wide.onset_sd_s is not None and d0.spread.onset_sd_s is not None
    assert wide.onset_sd_s > d0.spread.onset_sd_s

"""training_tests standardizes only the training samples it tests; it must give what
standardizing the whole residual, whitening it and then cutting the training window's
end out gives (and the same for a finding's stretches)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from analyzer import stats
from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis import evidence
from analyzer.diagnosis.evidence import (
    MAX_SEGMENT,
    WHITEN_FIT,
    fit_whitening,
    settled,
    standardized,
    training_tests,
)


def _result(dtype: type) -> DetectorResult:
    rng = np.random.default_rng(7)
    n = 3 * MAX_SEGMENT + 2 * WHITEN_FIT  # longer than anything the evidence reads at once
    a = (0.02 + 0.4 * rng.standard_normal(n)).astype(dtype)
    b = (0.3 * rng.standard_normal(n) + np.linspace(0.0, 1.0, n)).astype(dtype)
    b[MAX_SEGMENT // 3 : MAX_SEGMENT // 3 + 50] = np.nan  # a gap inside the training window
    return DetectorResult(
        "d",
        ("a", "b", "c"),
        {},
        [],
        {"a": a, "b": b, "c": np.zeros(n, dtype=dtype)},
        sigma={"a": 0.4, "b": 0.5, "c": 0.0},
        thresholds={"a": {"mean": 0.02, "std": 0.41}, "b": {"std": 0.0}},
    )


def _whitened_whole(z: np.ndarray, train: tuple[int, int]) -> np.ndarray:
    """The straightforward form of the whitening: the model fitted on the training
    window's end of the whole standardized residual, applied to all of it by the
    definition ``e[t] = (z[t] - sum_k a[k] z[t - k]) / scale`` (NaN where the window
    holds a gap or reaches before the start)."""
    a = max(settled(train), train[1] - WHITEN_FIT)
    w = fit_whitening(z[a : train[1]]) if train[1] - a >= evidence.MIN_SEGMENT else None
    if w is None:
        return z
    e = np.full(z.shape[0], np.nan)
    for t in range(w.order, z.shape[0]):
        past = z[t - w.order : t][::-1]
        e[t] = (z[t] - float(np.dot(w.coefficients, past))) / w.scale
    return e


def _reference(result: DetectorResult, train: tuple[int, int]) -> dict[str, Any]:
    """The straightforward form: the whole residual standardized, whitened, then cut."""
    out: dict[str, Any] = {}
    for ch, r in result.residuals.items():
        th = result.thresholds.get(ch, {})
        mean = float(th.get("mean", 0.0))
        std = float(th.get("std", result.sigma.get(ch, 0.0)))
        if not std > 0:
            std = float(result.sigma.get(ch, 0.0))
        if not std > 0:
            continue
        z = (np.asarray(r, dtype=np.float64) - mean) / std
        lo = max(settled(train), train[1] - MAX_SEGMENT)
        if train[1] - lo < evidence.MIN_SEGMENT:
            continue
        seg = _whitened_whole(z, train)[lo : train[1]]
        seg = seg[np.isfinite(seg)]
        if seg.shape[0] < evidence.MIN_SEGMENT:
            continue
        tests = stats.test_segment(seg)
        out[ch] = {
            k: {key: v.get(key) for key in ("statistic", "critical", "reject")}
            for k, v in tests.items()
        }
    return out


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
@pytest.mark.parametrize(
    "train",
    [
        (0, MAX_SEGMENT // 2),
        (100, 100 + 2 * MAX_SEGMENT),
        (5_000, 10**9),
        (10, 5),
        (10**9, 10**9 + 5),
    ],
)
def test_training_tests_equal_whole_residual_cut(dtype: type, train: tuple[int, int]) -> None:
    result = _result(dtype)
    got = training_tests(result, train)
    want = _reference(result, train)
    assert got.keys() == want.keys()
    for ch in got:  # the same tests; the statistics to rounding (convolution vs loop)
        # got also has mean_long_run (the mean against the long-run variance)
        assert set(got[ch]) == set(want[ch]) | {"mean_long_run"}
        for k in want[ch]:
            v = got[ch][k]
            assert v["reject"] == want[ch][k]["reject"], (ch, k)
            assert v["statistic"] == pytest.approx(want[ch][k]["statistic"], rel=1e-9, abs=1e-12)
    assert "c" not in got  # no healthy deviation: not tested


def test_standardized_part_equals_cut_of_whole() -> None:
    result = _result(np.float32)
    for ch in ("a", "b"):
        whole = standardized(result, ch)
        assert whole is not None and whole.dtype == np.float64
        part = standardized(result, ch, slice(123, 4567))
        assert part is not None
        np.testing.assert_array_equal(part, whole[123:4567])
    assert standardized(result, "c") is None
    assert standardized(result, "missing") is None


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_windowed_summary_standardizes_a_batch_at_a_time(dtype, monkeypatch):
    """windowed_summary hands each residual to the windowed tests raw, with its
    ``(mean, std)``, instead of a float64 standardized copy of the whole archive: the
    summaries of the residual standardized whole, and no whole-length copy is made."""
    from analyzer.stats import summarize, windowed_tests

    result = _result(dtype)
    want = {}
    for ch in result.residuals:
        z = standardized(result, ch)
        if z is not None:
            want[ch] = summarize(windowed_tests(z, 100))
    monkeypatch.setattr(evidence, "standardized", None)  # not called
    got = evidence.windowed_summary(result, 100.0)
    assert got.keys() == want.keys() == {"a", "b"}
    assert got == want


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("end_s", [None, 251.23])  # onset 201.23 s
def test_finding_evidence_standardizes_only_the_stretches_it_tests(dtype, end_s, monkeypatch):
    """attach_evidence tests the stretches before and after a finding's onset; it
    standardizes those two only (not the whole residual, as long as the archive): the
    tests of the whole residual standardized and then cut, the same values."""
    from analyzer.diagnosis.merge import Finding
    from analyzer.types import FaultType

    result = _result(dtype)
    rate, train = 100.0, (0, MAX_SEGMENT // 2)
    onset = MAX_SEGMENT + 123
    z = standardized(result, "a")
    n = z.shape[0]
    end = n if end_s is None else int(round(end_s * rate))
    lo = max(settled(train), onset - MAX_SEGMENT)
    e = _whitened_whole(z, train)
    want_before = evidence._tests(e[lo:onset])
    want_after = evidence._tests(e[onset : min(end, onset + MAX_SEGMENT)])
    finding = Finding(
        "a",
        FaultType.ADDITIVE,
        onset / rate,
        end_s,
        {"offset": 1.0},
        0.9,
        "d",
        {"detectors": ["d"]},
    )
    whole: list[int] = []
    real = evidence.standardized

    def spy(res, ch, part=None):
        out = real(res, ch, part)
        whole.append(out.shape[0])
        return out

    monkeypatch.setattr(evidence, "standardized", spy)
    evidence.attach_evidence([finding], [result], rate, train)
    got = finding.evidence["tests"]["d"]
    for side, want in (("before", want_before), ("after", want_after)):
        assert want is not None and got[side] is not None
        for k, v in got[side].items():
            assert v["reject"] == want[k]["reject"], (side, k)
            assert v["statistic"] == pytest.approx(want[k]["statistic"], rel=1e-9, abs=1e-12)
    assert got["whitening"]["order"] >= 0
    # the stretches and the whitening fit, never the whole residual
    assert max(whole) <= max(MAX_SEGMENT, WHITEN_FIT) < n


def test_windowed_summary_whitens_by_the_training_window_s_model():
    """With the training window, each residual's windows are tested whitened by its
    model of that window (the model the tests around an onset use): a strongly
    coloured healthy residual (AR(1) 0.9) rejected whiteness in every 1 s window."""
    from scipy.signal import lfilter

    rng = np.random.default_rng(3)
    r = lfilter([1.0], [1.0, -0.9], rng.standard_normal(60_000))
    std = float(np.std(r[:20_000]))
    result = DetectorResult(
        "d", ("a",), {}, [], {"a": r}, sigma={"a": std}, thresholds={"a": {"std": std}}
    )
    plain = evidence.windowed_summary(result, 100.0)["a"]
    white = evidence.windowed_summary(result, 100.0, train=(0, 20_000))["a"]
    assert "whitening_order" not in plain["windows"] and white["windows"]["whitening_order"] >= 1
    assert plain["whiteness"]["fraction"] > 0.9
    assert white["whiteness"]["fraction"] < 0.15

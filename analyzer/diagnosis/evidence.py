"""The statistical evidence behind each finding (seed 003: a correct model's
standardized innovation is zero-mean, unit-variance, Gaussian and white; a fault breaks
some of these, and *which* ones break speaks for the fault type).

For every detector that saw a finding, its residual on the finding's channel is
standardized with the detector's healthy mean and deviation, and the tests of
:mod:`analyzer.stats` run on the healthy stretch before the onset and on the faulty
stretch after it. The residuals of the leave-one-out estimators are coloured even when
healthy, so whiteness often rejects on both sides: the report shows both, and the
verdict leans on what *changes* across the onset.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.merge import Finding
from analyzer.errors import DetectorError
from analyzer.paging import release
from analyzer.stats import summarize, test_segment, windowed_tests
from analyzer.stats._checks import standardize
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

MAX_SEGMENT = 20_000
"""Samples tested on each side of an onset (tests on longer stretches only get slower)."""
MIN_SEGMENT = 30
DISAGREEMENT_FACTOR = 0.8
"""Confidence factor when the after-onset tests do not point to the finding's type."""


def standardized(
    result: DetectorResult, channel: str, part: slice | None = None
) -> FloatArray | None:
    """The detector's residual on ``channel`` (its samples ``part`` only, when given) in
    units of its healthy deviation."""
    r = result.residuals.get(channel)
    scaling = _scaling(result, channel)
    if r is None or scaling is None:
        return None
    mean, std = scaling
    return standardize(np.asarray(r if part is None else r[part]), mean, std)


def _standard_part(result: DetectorResult, channel: str, part: slice) -> FloatArray:
    """:func:`standardized` of a channel known to have a residual and a deviation."""
    z = standardized(result, channel, part)
    assert z is not None
    return z


def _scaling(result: DetectorResult, channel: str) -> tuple[float, float] | None:
    """The ``(mean, std)`` that :func:`standardized` uses for ``channel`` (None: no
    healthy deviation known)."""
    th = result.thresholds.get(channel, {})
    mean = float(th.get("mean", 0.0)) if isinstance(th, dict) else 0.0
    std = float(th.get("std", result.sigma.get(channel, 0.0))) if isinstance(th, dict) else 0.0
    if not std > 0:
        std = float(result.sigma.get(channel, 0.0))
    if not std > 0:
        return None
    return mean, std


def _tests(z: FloatArray) -> dict[str, Any] | None:
    z = z[np.isfinite(z)]
    if z.shape[0] < MIN_SEGMENT:
        return None
    try:
        return test_segment(z)
    except DetectorError:
        return None


def consistent_types(after: dict[str, Any]) -> list[str]:
    """Fault types the broken properties point to (seed 003): a rejected mean test speaks
    for an offset or a drift; a rejected covariance test without a rejected mean for a
    gain change; a rejected whiteness test also for a drift (a slow trend)."""
    mean = bool(after.get("mean", {}).get("reject"))
    cov = bool(after.get("covariance", {}).get("reject"))
    white = bool(after.get("whiteness", {}).get("reject"))
    out = []
    if mean:
        out += [FaultType.ADDITIVE.value, FaultType.DRIFT.value]
    elif cov:
        out.append(FaultType.MULTIPLICATIVE.value)
    if white and FaultType.DRIFT.value not in out:
        out.append(FaultType.DRIFT.value)
    if cov or mean:
        out.append(FaultType.OTHER.value)
    return out


def attach_evidence(
    findings: list[Finding], results: list[DetectorResult], rate_hz: float, train: tuple[int, int]
) -> None:
    """Fill ``finding.evidence["tests"][detector]`` with before/after test results."""
    by_name = {r.detector: r for r in results}
    for f in findings:
        tests: dict[str, Any] = {}
        for det in f.evidence.get("detectors", []):
            res = by_name.get(det)
            if res is None:
                continue
            r = res.residuals.get(f.channel)
            if r is None or _scaling(res, f.channel) is None:
                continue
            onset = int(round(f.onset_s * rate_hz))
            end = r.shape[0] if f.end_s is None else int(round(f.end_s * rate_hz))
            lo = max(train[0], onset - MAX_SEGMENT)
            # only the two stretches tested are standardized (not a float64 copy of the
            # whole residual: as long as the archive), the same bits
            spans = (slice(lo, onset), slice(onset, min(end, onset + MAX_SEGMENT)))
            before, after = (_tests(_standard_part(res, f.channel, s)) for s in spans)
            release(r)  # a long archive's residual: pages back to the cache
            if after is None:
                continue
            tests[det] = {
                "before": before,
                "after": after,
                "before_span_s": [lo / rate_hz, onset / rate_hz],
                "after_span_s": [onset / rate_hz, min(end, onset + MAX_SEGMENT) / rate_hz],
                "consistent_with": consistent_types(after),
            }
        f.evidence["tests"] = tests
        lead = tests.get(f.detector)
        if lead is not None:
            agree = f.type.value in lead["consistent_with"]
            f.evidence["tests_agree"] = agree
            if not agree:
                # the innovation tests do not break the way this fault type breaks them
                f.confidence *= DISAGREEMENT_FACTOR


def training_tests(
    result: DetectorResult, train: tuple[int, int], channels: Sequence[str] | None = None
) -> dict[str, Any]:
    """Tests of each channel's residual (of ``channels`` only, when given) over the
    training window: a model whose training residuals fail normality or whiteness badly is
    a poor model, and the report says so."""
    out: dict[str, Any] = {}
    for ch in result.residuals if channels is None else channels:
        # the first MAX_SEGMENT training samples, not the whole (long) residual
        z = standardized(result, ch, slice(train[0], min(train[1], train[0] + MAX_SEGMENT)))
        if z is None:
            continue
        t = _tests(z)
        release(result.residuals[ch])  # a long archive's residual: pages back to the cache
        if t is not None:
            out[ch] = {
                k: {
                    "statistic": v.get("statistic"),
                    "critical": v.get("critical"),
                    "reject": v.get("reject"),
                }
                for k, v in t.items()
            }
    return out


def windowed_summary(
    result: DetectorResult,
    rate_hz: float,
    window_s: float = 1.0,
    channels: Sequence[str] | None = None,
) -> dict[str, Any]:
    """Per channel (of ``channels`` only, when given): the innovation tests on consecutive
    windows over the whole archive (vectorized, :func:`analyzer.stats.windowed_tests`),
    summarized as the share of windows each test rejects (about 5 % for a healthy,
    well-modelled residual)."""
    window = max(100, int(round(window_s * rate_hz)))
    out: dict[str, Any] = {}
    for ch in result.residuals if channels is None else channels:
        r = result.residuals.get(ch)
        scaling = _scaling(result, ch)
        if r is None or scaling is None or r.shape[0] < window:
            continue
        try:
            # standardized a batch at a time, as standardized() does it whole: a long
            # archive's residual is read in pieces, not copied whole to float64
            out[ch] = summarize(windowed_tests(r, window, standardize=scaling))
        except DetectorError:
            continue
        finally:
            release(r)  # a long archive's residual: pages back to the cache
    return out

"""The statistical evidence behind each finding (seed 003: a correct model's
standardized innovation is zero-mean, unit-variance, Gaussian and white; a fault breaks
some of these, and *which* ones break speaks for the fault type).

For every detector that saw a finding, its residual on the finding's channel is
standardized with the detector's healthy mean and deviation, *whitened* (below), and the
tests of :mod:`analyzer.stats` run on the healthy stretch before the onset and on the
faulty stretch after it.

The detectors' residuals are not a Kalman filter's innovations: a leave-one-out
estimate's error, an observer's fault estimate or a detection filter's output are
coloured even when healthy (lag-1 autocorrelation 0.7 and more). Tested as they are, the
healthy stretch before a simulated fault's onset failed whiteness in 103 of 103 tests,
Anderson-Darling in 67, the mean test in 50 and the covariance test in 52: the tests
said nothing the fault changed. So each residual is first turned into the innovations of
its own healthy process (prewhitening): an autoregressive model of order up to
:data:`WHITEN_MAX_ORDER`, chosen by AIC, is fitted on the end of the training window
(Yule-Walker, by Levinson-Durbin), and its one-step prediction error, in units of its
healthy deviation, is what is tested. A fault breaks the properties it breaks (an offset
the mean, a gain the covariance, a drift the mean and whiteness). The filter goes with
the tests in the evidence (``whitening``), so the report draws what was tested.

A healthy stretch still rejects more often than the nominal 5 % (ux54 item 4;
``benchmarks/sweep_evidence.py``, seeds 500-507, 3 layouts, 186 healthy stretches before
true onsets: whiteness 15-31 %, covariance 9-24 %, Anderson-Darling 3-16 %, mean 0-18 %,
Shewhart 0-6 %). Two causes, measured on healthy records: the whitening model is
estimated on the 4 500 settled samples of a 60 s window and applied to 2 000 others (on
a simulated Gaussian AR process of the same order, which has white innovations, that
alone rejected whiteness out of sample in 17 % of stretches, 0 % in sample); and the
residuals are not a stationary Gaussian process beyond what an AR model of the window
takes out (a model fitted just before the stretch rejected whiteness as often, the
covariance ratio of 2 000 samples spread 0.04 against chi-square's 0.032, the mean
wanders beyond the whiteness test's lags, which the long-run mean test does not catch
either). The tests' critical values are therefore not calibrated to 5 % on a healthy
stretch: read a ``before`` rejection as this model's healthy behaviour, and an ``after``
rejection as weaker evidence than its level says; the type vote rests on the mean and
covariance, which a fault moves far beyond these (every simulated offset and gain).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import numpy.typing as npt

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.merge import Finding
from analyzer.errors import DetectorError
from analyzer.paging import release
from analyzer.stats import summarize, test_segment, windowed_tests
from analyzer.stats._checks import standardize
from analyzer.stats.moments import long_run_mean_test
from analyzer.stats.whiten import whiten
from analyzer.types import FaultType

FloatArray = npt.NDArray[np.float64]

MAX_SEGMENT = 2_000
"""Samples tested on each side of an onset, and at the training window's end. The tests
are built for a series whose model is right; over 20 000 samples (the length before) a
whitened healthy residual with autocorrelations of 0.01-0.02 at every lag (a slow
wander no model of the training window takes out) failed Ljung-Box in 97 of 103 healthy
stretches before simulated faults' onsets, and the mean test in 21; over 2 000, 14 and
8 then (the audit ux54 measured 15-34 % and 0-18 % on more seeds and layouts: module
docstring), while every fault still broke what it breaks after its onset (36 of 36
offsets the mean, 36 of 36 gains the covariance)."""
MIN_SEGMENT = 30
DISAGREEMENT_FACTOR = 0.8
"""Confidence factor when the after-onset tests do not point to the finding's type."""
WHITEN_MAX_ORDER = 30
"""Highest order of the whitening model (AIC chooses up to it)."""
WHITEN_FIT = 20_000
"""Samples at the end of the training window the whitening model is fitted on (its start
holds the filters' settling)."""


@dataclass(frozen=True, slots=True)
class Whitening:
    """The whitening filter of one standardized residual: ``e[t] = (z[t] - sum_k a[k] *
    z[t - k]) / scale`` with ``a = coefficients`` (lags 1..order)."""

    coefficients: tuple[float, ...]
    scale: float

    @property
    def order(self) -> int:
        return len(self.coefficients)

    def apply(self, z: FloatArray, history: int) -> FloatArray:
        """The whitened ``z[history:]``, where ``z`` starts ``history`` samples (at most
        :attr:`order`) before the stretch wanted (:func:`analyzer.stats.whiten.whiten`)."""
        return whiten(z, self.coefficients, self.scale, history)

    def as_dict(self) -> dict[str, Any]:
        return {"order": self.order, "coefficients": list(self.coefficients), "scale": self.scale}

    @classmethod
    def from_dict(cls, d: Any) -> Whitening | None:
        if not isinstance(d, dict):
            return None
        try:
            return cls(tuple(float(a) for a in d["coefficients"]), float(d["scale"]))
        except (KeyError, TypeError, ValueError):
            return None


def fit_whitening(
    z: FloatArray, max_order: int = WHITEN_MAX_ORDER, order: int | None = None
) -> Whitening | None:
    """The AR model of a standardized healthy residual ``z`` (NaN: gaps) by Yule-Walker
    (the biased autocovariances of the demeaned series, NaN taken as 0 and the sums
    divided by the finite samples' count; solved for every order by Levinson-Durbin), of
    the order from 0 to ``max_order`` with the lowest AIC, or of ``order`` when given;
    None when ``z`` has too few finite samples or no variance."""
    ok = np.isfinite(z)
    n = int(ok.sum())
    p_max = min(max_order if order is None else order, n // 10)
    if n < MIN_SEGMENT or p_max < 0:
        return None
    x = np.where(ok, z - float(np.mean(z[ok])), 0.0)
    acov = np.array([float(np.dot(x[k:], x[: x.shape[0] - k])) / n for k in range(p_max + 1)])
    if not acov[0] > 0:
        return None
    a = np.zeros(0)
    err = float(acov[0])
    best = (n * np.log(err), a, err)
    for k in range(1, p_max + 1):
        # Levinson-Durbin: the order-k reflection coefficient from the order-(k-1) model
        refl = (acov[k] - float(np.dot(a, acov[k - 1 : 0 : -1]))) / err
        if not abs(refl) < 1.0:
            break
        a = np.concatenate((a - refl * a[::-1], [refl]))
        err *= 1.0 - refl * refl
        aic = n * np.log(err) + 2 * k
        if aic < best[0] or k == order:
            best = (aic, a, err)
    _, coef, var = best
    return Whitening(tuple(float(c) for c in coef), float(np.sqrt(var)))


def settled(train: tuple[int, int]) -> int:
    """Where the training window's residuals are taken as settled: after its first
    quarter (the filters start from their zero state at the record's start)."""
    return train[0] + max(0, train[1] - train[0]) // 4


def _whitening(result: DetectorResult, channel: str, train: tuple[int, int]) -> Whitening | None:
    """:func:`fit_whitening` of the detector's standardized residual on ``channel`` over
    the last :data:`WHITEN_FIT` samples of the training window (after its first
    quarter)."""
    a = max(settled(train), train[1] - WHITEN_FIT)
    if train[1] - a < MIN_SEGMENT:
        return None
    z = standardized(result, channel, slice(a, train[1]))
    return None if z is None else fit_whitening(z)


def whitened_part(
    result: DetectorResult, channel: str, part: slice, whitening: Whitening | None
) -> FloatArray:
    """:func:`standardized` of ``part`` (a channel known to have a residual and a
    deviation), whitened by ``whitening`` when given (reading the samples before
    ``part.start`` its filter needs)."""
    if whitening is None:
        return _standard_part(result, channel, part)
    start = max(0, part.start - whitening.order)
    z = _standard_part(result, channel, slice(start, part.stop))
    if start > part.start - whitening.order:  # the data begin inside the filter's reach
        z = np.concatenate((np.full(start - (part.start - whitening.order), np.nan), z))
    return whitening.apply(z, whitening.order)


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
    """The innovation tests of one stretch (:func:`analyzer.stats.test_segment`), and the
    mean held against the stretch's long-run variance over the whiteness test's lags
    (``mean_long_run``, :func:`analyzer.stats.moments.long_run_mean_test`): the mean
    test assumes whiteness, and :func:`consistent_types` reads this one where whiteness
    is rejected."""
    z = z[np.isfinite(z)]
    if z.shape[0] < MIN_SEGMENT:
        return None
    try:
        out = test_segment(z)
        lags = out["whiteness"]["lags"]
        assert isinstance(lags, int)
        out["mean_long_run"] = long_run_mean_test(z, lags).as_dict()
    except DetectorError:
        return None
    return out


def consistent_types(after: dict[str, Any]) -> list[str]:
    """Fault types the broken properties point to (seed 003): a rejected mean test speaks
    for an offset or a drift; a rejected covariance test without a rejected mean for a
    gain change; a rejected whiteness test also for a drift (a slow trend).

    The mean test holds the mean against the healthy unit deviation, which assumes a
    white stretch (seed 003 tests whiteness first). Where whiteness is rejected, the
    mean is judged against the stretch's long-run variance (``mean_long_run``: the
    variance of its mean under the correlation the whiteness test found, about its own
    mean, so a larger spread counts too): a gain multiplies the structure's coloured
    response, and its after-onset stretch (Ljung-Box Q of 1 000-19 000 against 31.4)
    moved the plain mean past 1.96 in most simulated gains; with the spread alone
    (below) 16 of 75 right gains still pointed to an offset, with the long-run variance
    the t statistics of those fell to 0.2-0.9. Where whiteness holds and the covariance
    test rejected a larger spread, the mean is judged against the stretch's own
    deviation (:func:`_mean_beyond_spread`)."""
    mean = _mean_rejected(after)
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


def mean_test_read(after: Mapping[str, Any]) -> str:
    """Which mean test :func:`consistent_types` reads of the stretch after the onset:
    ``mean_long_run`` where whiteness is rejected and it ran, else ``mean`` (held against
    the stretch's own deviation where the covariance test rejected a larger spread,
    :func:`_mean_beyond_spread`). The report says which, beside both."""
    long_run = after.get("mean_long_run")
    if bool((after.get("whiteness") or {}).get("reject")) and isinstance(long_run, Mapping):
        return "mean_long_run"
    return "mean"


def _mean_rejected(after: dict[str, Any]) -> bool:
    """The mean's verdict for :func:`consistent_types`: the long-run mean test's where
    whiteness is rejected and it ran, else :func:`_mean_beyond_spread`'s."""
    if mean_test_read(after) == "mean_long_run":
        return bool(after["mean_long_run"].get("reject"))
    return _mean_beyond_spread(after)


def _mean_beyond_spread(after: dict[str, Any]) -> bool:
    """The mean test's verdict, with the mean held against the stretch's own deviation
    (a t statistic: ``sqrt(N) |mean| / s`` with ``s^2 = ratio - mean^2`` from the
    covariance test's mean square) where the covariance test rejected a spread larger
    than the healthy one."""
    m = after.get("mean", {})
    reject = bool(m.get("reject"))
    c = after.get("covariance", {})
    ratio, means = c.get("ratio"), m.get("mean")
    if not (reject and c.get("reject") and isinstance(ratio, float) and ratio > 1.0):
        return reject
    if not isinstance(means, list) or len(means) != 1 or not isinstance(means[0], float):
        return reject
    spread = ratio - means[0] ** 2
    if not spread > 1.0:
        return reject
    return float(m.get("statistic", 0.0)) / float(np.sqrt(spread)) > float(m.get("critical", 0.0))


def _healthy_until(f: Finding, onset: int, rate_hz: float) -> int:
    """Where the stretch tested as healthy before ``f``'s onset ends: the onset, or for a
    fault a search again after a stretch of another load found already there
    (``searched_after``), that stretch's start: the fault may have begun anywhere in it,
    and the stretch itself is no healthy reference (the tests rejected everything on
    the burst's end and the fault's first seconds)."""
    after = f.evidence.get("searched_after")
    if isinstance(after, dict) and after.get("onset_at_or_before"):
        return min(onset, int(round(float(after["stretch_s"][0]) * rate_hz)))
    return onset


def attach_evidence(
    findings: list[Finding],
    results: list[DetectorResult],
    rate_hz: float,
    train: tuple[int, int],
    whiten: bool = True,
) -> None:
    """Fill ``finding.evidence["tests"][detector]`` with before/after test results, on
    the residual whitened by its model of the training window (``whiten`` False: a
    record without a healthy window of its own, ``--model``, is tested unwhitened)."""
    by_name = {r.detector: r for r in results}
    whitening: dict[tuple[str, str], Whitening | None] = {}
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
            healthy_end = _healthy_until(f, onset, rate_hz)
            lo = min(healthy_end, max(settled(train), healthy_end - MAX_SEGMENT))
            # only the two stretches tested are standardized (not a float64 copy of the
            # whole residual: as long as the archive), the same bits
            spans = (slice(lo, healthy_end), slice(onset, min(end, onset + MAX_SEGMENT)))
            key = (det, f.channel)
            if key not in whitening:
                whitening[key] = _whitening(res, f.channel, train) if whiten else None
            w = whitening[key]
            before, after = (_tests(whitened_part(res, f.channel, s, w)) for s in spans)
            release(r)  # a long archive's residual: pages back to the cache
            if after is None:
                continue
            tests[det] = {
                "before": before,
                "after": after,
                "before_span_s": [lo / rate_hz, healthy_end / rate_hz],
                "after_span_s": [onset / rate_hz, min(end, onset + MAX_SEGMENT) / rate_hz],
                "consistent_with": consistent_types(after),
            }
            if w is not None:
                tests[det]["whitening"] = w.as_dict()
        f.evidence["tests"] = tests
        lead = tests.get(f.detector)
        if lead is not None:
            agree = f.type.value in lead["consistent_with"]
            f.evidence["tests_agree"] = agree
            if not agree:
                # the innovation tests do not break the way this fault type breaks them
                f.confidence *= DISAGREEMENT_FACTOR


def whitenings(
    result: DetectorResult, train: tuple[int, int], channels: Sequence[str] | None = None
) -> dict[str, Whitening | None]:
    """Each channel's (of ``channels`` only, when given) whitening model of the training
    window (:func:`fit_whitening`), for :func:`training_tests` and
    :func:`windowed_summary` to share."""
    return {
        ch: _whitening(result, ch, train) if _scaling(result, ch) is not None else None
        for ch in (result.residuals if channels is None else channels)
        if ch in result.residuals
    }


def training_tests(
    result: DetectorResult,
    train: tuple[int, int],
    channels: Sequence[str] | None = None,
    fitted: Mapping[str, Whitening | None] | None = None,
) -> dict[str, Any]:
    """Tests of each channel's residual (of ``channels`` only, when given) over the
    end of the training window (its last :data:`MAX_SEGMENT` samples after its first
    quarter), whitened as the stretches around an onset are: a residual that fails
    normality even so, or stays coloured beyond its whitening model, is a poor model,
    and the report says so. ``fitted``: the channels' whitening models
    (:func:`whitenings`), else fitted here."""
    out: dict[str, Any] = {}
    for ch in result.residuals if channels is None else channels:
        # MAX_SEGMENT training samples, not the whole (long) residual
        if ch not in result.residuals or _scaling(result, ch) is None:
            continue
        lo = max(settled(train), train[1] - MAX_SEGMENT)
        if train[1] - lo < MIN_SEGMENT:
            continue
        w = fitted[ch] if fitted is not None and ch in fitted else _whitening(result, ch, train)
        t = _tests(whitened_part(result, ch, slice(lo, train[1]), w))
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
    train: tuple[int, int] | None = None,
    fitted: Mapping[str, Whitening | None] | None = None,
) -> dict[str, Any]:
    """Per channel (of ``channels`` only, when given): the innovation tests on consecutive
    windows over the whole archive (vectorized, :func:`analyzer.stats.windowed_tests`),
    summarized as the share of windows each test rejects (about 5 % for a healthy,
    well-modelled residual), on the residual whitened by its model of the training
    window ``train`` (as the tests around an onset; not whitened without one;
    ``fitted``: those models, :func:`whitenings`, else fitted here). With ``train``,
    each test also counts its rejecting windows inside that window after its first
    quarter (``training_fraction`` and its counts): a real residual is rarely white or
    normal even when healthy, so its healthy share, not the nominal 5 %, is what the
    record's is read against."""
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
            if train is None:
                w = None
            elif fitted is not None and ch in fitted:
                w = fitted[ch]
            else:
                w = _whitening(result, ch, train)
            white = None if w is None else (w.coefficients, w.scale)
            # each test's share of rejecting windows inside the training window (after
            # its first quarter, as the whitening's fit): the healthy reference
            out[ch] = summarize(
                windowed_tests(r, window, standardize=scaling, whitening=white),
                reference=None if train is None else (settled(train), train[1]),
            )
            if w is not None:  # in the window layout: the tests' entries are all objects
                out[ch]["windows"]["whitening_order"] = w.order
        except DetectorError:
            continue
        finally:
            release(r)  # a long archive's residual: pages back to the cache
    return out

"""The fast forms of the per-sample passes after the detectors' estimates, each against
the straightforward form it replaces:

* :func:`diagnose_interval`, which finds the corrected residual's alarms on a growing
  stretch from the fault's onset, against the whole-record form (the corrected residual
  over the whole record, its alarms and the raw residual's to the record's end);
* the compiled alarm statistic (two windows specialized, logs skipped by bounds, a
  gap-free path, running sums carried from call to call) against the kernel it replaced,
  kept here verbatim, bit for bit, and against the numpy moving means."""

import dataclasses
import math

import numpy as np
import pytest
from scipy.signal import lfilter

from analyzer.diagnosis.changes import (
    Calibration,
    Interval,
    _alarm_statistic_numpy,
    alarm_statistic,
    calibrate,
    detect,
)
from analyzer.diagnosis.classify import Classification, classify
from analyzer.diagnosis.events import (
    MAX_REFITS,
    REFIT_GROWTH,
    _confined,
    _gain_ended,
    _Intervals,
    diagnose_interval,
    events_from_residual,
)
from analyzer.types import FaultType

RATE = 100.0


def _whole_record_diagnosis(
    residual: np.ndarray,
    reference: np.ndarray | None,
    cal: Calibration,
    iv: Interval,
    rate_hz: float,
    tau_corr: float = 1.0,
    classify_until: int | None = None,
    *,
    statistic: np.ndarray | None = None,
) -> tuple[Classification, int | None]:
    """diagnose_interval as it was: the fault shape over the whole rest of the record,
    the corrected residual's alarms and the raw residual's to the record's end (each
    refit's corrected residual over the whole record too)."""
    n = residual.shape[0]
    limit = n if classify_until is None else max(iv.onset + 3, classify_until)
    stop = min(n if iv.end is None else iv.end, limit)
    r = np.asarray(residual, dtype=np.float64)
    ref = None if reference is None else np.asarray(reference, dtype=np.float64)

    def fit(stop: int) -> Classification:
        seg_ref = None if ref is None else ref[iv.onset : stop]
        return classify(r[iv.onset : stop] - cal.mean, seg_ref, cal.std, rate_hz, tau_corr)

    cls = fit(stop)
    tau = np.arange(n - iv.onset) / rate_hz
    shape = cls.fault_signal(tau, None if ref is None else ref[iv.onset :])
    if shape is None:
        return _confined(r, cls, cal, iv)  # no shape: nothing grows past the alarms
    corrected = r.copy()
    corrected[iv.onset :] -= shape
    corrected[iv.onset :] /= cls.reading_gain
    end: int | None = None
    raw_alarms = detect(r, cal, search_start=iv.onset, statistic=statistic)
    corrected_alarms = detect(corrected, cal, search_start=iv.onset + cal.window)
    if iv.end is not None and any(c.onset < iv.end for c in corrected_alarms):
        return cls, iv.end
    fitted_to, refits = stop, 0
    k = 0
    while k < len(corrected_alarms):
        civ = corrected_alarms[k]
        lo, hi = civ.onset + cal.window, civ.onset + cal.long_window
        recovered = not any(
            a.onset < hi and (n if a.end is None else a.end) > lo for a in raw_alarms
        )
        if recovered:
            end = civ.onset
            break
        # the shape failing while the raw residual alarms: refitted up to here (on a
        # stretch REFIT_GROWTH times the last at least), the corrected alarms found again
        grown = min(hi, limit)
        if refits < MAX_REFITS and grown - iv.onset >= REFIT_GROWTH * (fitted_to - iv.onset):
            fitted_to, refits = grown, refits + 1
            refit = fit(fitted_to)
            shape = refit.fault_signal(tau, None if ref is None else ref[iv.onset :])
            if shape is None:  # not taken; no more refits
                refits = MAX_REFITS
            else:
                cls = refit
                corrected = r.copy()
                corrected[iv.onset :] -= shape
                corrected[iv.onset :] /= cls.reading_gain
                corrected_alarms = detect(corrected, cal, search_start=iv.onset + cal.window)
                k = 0
                continue
        k += 1
    gain = cls.type is FaultType.MULTIPLICATIVE and ref is not None
    if gain and iv.end is not None and end is None:
        # (the gain's end test past the raw alarms, on the whole arrays)
        stop_at = n if end is None else end
        ended = _gain_ended(r, ref, cls, cal, None, iv.end, stop_at, tau_corr)
        end = end if ended is None else ended
    if end != iv.end:
        cls = fit(min(n if end is None else end, limit))
    return cls, end


def _structure(seed: int, n: int) -> np.ndarray:
    """A lightly damped structural response (the fault-free estimate), with quiet
    stretches where a gain fault is invisible."""
    rng = np.random.default_rng(seed)
    y = lfilter([1.0], [1.0, -1.95, 0.96], rng.standard_normal(n)) * 0.05
    envelope = np.ones(n)
    for a in range(n // 7, n, n // 3):
        envelope[a : a + n // 20] = 0.02
    return y * envelope


def _residual(seed: int, n: int) -> np.ndarray:
    e = np.random.default_rng(seed + 100).standard_normal(n)
    return 0.02 * lfilter([1.0], [1.0, -0.6], e)


def _cases() -> list[tuple[str, np.ndarray, np.ndarray]]:
    """Residuals with faults that end, faults that do not, gain faults, drifts, several
    faults in one record, and gaps."""
    n = 40_000
    out = []
    ref = _structure(1, n)
    r = _residual(1, n)
    r[12_000:15_000] += 0.1  # an offset that ends
    out.append(("offset ends", r, ref))
    r = _residual(2, n)
    r[20_000:] += 0.08  # an offset to the end
    out.append(("offset to the end", r, ref))
    r = _residual(3, n)
    r[10_000:30_000] += 0.6 * ref[10_000:30_000]  # a gain fault across quiet stretches
    out.append(("gain ends", r, ref))
    r = _residual(4, n)
    r[25_000:] += 0.8 * ref[25_000:]  # a gain fault to the end
    out.append(("gain to the end", r, ref))
    r = _residual(5, n)
    r[15_000:22_000] += 0.002 * np.arange(7_000) / 100.0  # a drift, then reset
    out.append(("drift", r, ref))
    r = _residual(6, n)
    r[9_000:10_000] += 0.12  # several faults, one record, a gap in one of them
    r[14_000:19_000] += 0.7 * ref[14_000:19_000]
    r[16_000:16_300] = np.nan
    r[24_000:24_200] += 0.3
    r[31_000:] += 0.0015 * np.arange(n - 31_000) / 100.0
    out.append(("several", r, ref))
    r = _residual(7, n)
    r[18_000:18_400] = 0.0  # a stuck stretch (type other) and a noise burst
    r[26_000:27_000] += 0.1 * np.random.default_rng(7).standard_normal(1000)
    out.append(("other", r, ref))
    r = _residual(9, n)
    r[15_000:30_000] += 0.0004 * np.arange(15_000) / 100.0  # a slow drift, then reset
    out.append(("slow drift", r, ref))
    return out


@pytest.mark.parametrize("steps", [(8.0, 8), (0.07, 2), (0.5, 3)])
@pytest.mark.parametrize("case", range(8))
def test_diagnosis_on_a_growing_stretch_equals_the_whole_record_form(
    case: int, steps: tuple[float, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """With the default steps and with short ones (the stretch ends inside alarm runs,
    between runs that merge, inside change-point searches)."""
    monkeypatch.setattr(_Intervals, "FIRST_STEP", steps[0])
    monkeypatch.setattr(_Intervals, "GROWTH", steps[1])
    name, r, ref = _cases()[case]
    start = 6000
    cal = calibrate(r[:start], 25)
    stat = alarm_statistic(r, cal, raw=True, start=start)
    ivs = detect(r, cal, search_start=start, statistic=stat)
    assert ivs, name
    ends = []
    for k, iv in enumerate(ivs):
        until = ivs[k + 1].onset if k + 1 < len(ivs) else None
        for reference in (ref, None):
            for kw in ({}, {"statistic": stat}):
                want = _whole_record_diagnosis(r, reference, cal, iv, RATE, 2.0, **kw)
                got = diagnose_interval(r, reference, cal, iv, RATE, 2.0, **kw)
                assert got == want, (name, k, kw.keys())
                ends.append(want[1])
            want = _whole_record_diagnosis(r, reference, cal, iv, RATE, 2.0, until)
            assert diagnose_interval(r, reference, cal, iv, RATE, 2.0, until) == want
    if case in (1, 3):  # a fault to the end: the search went to the end of the record
        assert None in ends
    # the whole path (events) as well
    assert events_from_residual("c", r, ref, cal, RATE, "d", search_start=start)


def test_the_cases_cover_faults_that_end_past_their_alarms() -> None:
    """The corrected residual moves some ends past the raw alarms (what the lazy search
    must find), and leaves others at the end of the record."""
    moved, to_end = 0, 0
    for _, r, ref in _cases():
        cal = calibrate(r[:6000], 25)
        for iv in detect(r, cal, search_start=6000):
            _, end = _whole_record_diagnosis(r, ref, cal, iv, RATE)
            moved += end is not None and end != iv.end
            to_end += end is None
    assert moved >= 1
    assert to_end >= 1


def _old_alarm_loop(x, mean, std, windows, mthr, lqm, lqden, start, out):  # type: ignore[no-untyped-def]
    """The alarm kernel before the two-window path (verbatim)."""
    n = x.shape[0]
    k = windows.shape[0]
    wmax = windows.max()
    ring = 1
    while ring <= wmax:
        ring *= 2
    mask = ring - 1
    c1 = np.zeros(ring)
    c2 = np.zeros(ring)
    cf = np.zeros(ring, dtype=np.int64)
    inv_std = 1.0 / std
    a = 1.0 / (windows * mthr)
    lw = lqm + np.log(windows.astype(np.float64))
    floor = np.exp(lw)
    inv_floor = 1.0 / floor
    g = 1.0 / lqden
    d2s = np.zeros(k)
    s1 = 0.0
    s2 = 0.0
    sf = 0
    first = max(0, min(start, n) - wmax + 1)
    for t in range(first):
        v = (np.float64(x[t]) - mean) * inv_std
        if np.isfinite(v):
            s1 += v
            s2 += v * v
            sf += 1
    c1[first & mask] = s1
    c2[first & mask] = s2
    cf[first & mask] = sf
    for t in range(first, n):
        v = (np.float64(x[t]) - mean) * inv_std
        if np.isfinite(v):
            s1 += v
            s2 += v * v
            sf += 1
        j = (t + 1) & mask
        c1[j] = s1
        c2[j] = s2
        cf[j] = sf
        if t < start:
            continue
        best = 0.0
        for i in range(k):
            w = windows[i]
            d2s[i] = 0.0
            if t + 1 < w:
                continue
            b = (t + 1 - w) & mask
            if 2 * (sf - cf[b]) <= w:
                continue
            m = abs(s1 - c1[b]) * a[i]
            if m > best:
                best = m
            d2s[i] = s2 - c2[b]
        for i in range(k):
            d2 = d2s[i]
            if d2 > floor[i]:
                u = d2 * inv_floor[i] - 1.0
                if (u * (6.0 + u) / (6.0 + 4.0 * u) * (1.0 + 1e-12) + 1e-9) * g[i] < best:
                    continue
                q = (math.log(d2) - lw[i]) * g[i]
                if q > best:
                    best = q
        out[t] = best


_old_kernel = None


def _old_statistic(x: np.ndarray, cal: Calibration, raw: bool, start: int = 0) -> np.ndarray:
    global _old_kernel
    if _old_kernel is None:
        from numba import njit

        _old_kernel = njit(_old_alarm_loop)
    k = len(cal.windows)
    zc = cal.z_crit
    mthr = np.array([zc * cal.mean_sd[i] for i in range(k)])
    lqden = np.array(
        [(cal.logq_mean[i] + zc * cal.logq_sd[i]) - cal.logq_mean[i] for i in range(k)]
    )
    mean, std = (cal.mean, cal.std) if raw else (0.0, 1.0)
    out = np.zeros(x.shape[0])
    _old_kernel(
        x,
        mean,
        std,
        np.asarray(cal.windows, dtype=np.int64),
        mthr,
        np.asarray(cal.logq_mean, dtype=np.float64),
        lqden,
        max(0, start),
        out,
    )
    return out


def _records() -> list[np.ndarray]:
    """Healthy, alarmed throughout (both log statistics high: the tangent bounds), a
    gain change and offsets, gaps and infinities, a constant stretch."""
    n = 30_000
    out = []
    for name, r, _ in _cases():
        out.append(r)
        if name == "several":
            out.append(r * 6.0)  # alarmed nearly everywhere
    r = _residual(9, n)
    r[3000:3100] = np.nan
    r[7000] = np.inf
    r[7001] = -np.inf
    r[12_000:12_500] = 0.02  # constant
    r[20_000:] *= 40.0  # far above the floor to the end
    out.append(r)
    return out


def test_alarm_kernel_is_the_previous_kernel_bit_for_bit() -> None:
    records = _records()
    cal = calibrate(_residual(1, 40_000)[:6000], 25)
    for k, r in enumerate(records):
        for start in (0, 1, 24, 199, 200, 6000, r.shape[0] - 3, r.shape[0] + 5):
            want = _old_statistic(r, cal, True, start)
            np.testing.assert_array_equal(
                alarm_statistic(r, cal, raw=True, start=start), want, err_msg=f"{k} {start}"
            )
        z = cal.standardize(r)
        np.testing.assert_array_equal(alarm_statistic(z, cal), _old_statistic(z, cal, False))
        r32 = r.astype(np.float32)
        np.testing.assert_array_equal(
            alarm_statistic(r32, cal, raw=True), _old_statistic(r32, cal, True)
        )
        finite = np.isfinite(z).all()
        tol = 1e-9 if finite else 1e-8
        np.testing.assert_allclose(
            alarm_statistic(z, cal), _alarm_statistic_numpy(z, cal), rtol=tol, atol=tol
        )


@pytest.mark.parametrize("windows", [(25,), (25, 200, 50)])
def test_alarm_kernel_with_other_window_counts(windows: tuple[int, ...]) -> None:
    """A calibration with one or three windows takes the general loop."""
    cal0 = calibrate(_residual(1, 40_000)[:6000], 25)
    k = len(windows)
    cal = dataclasses.replace(
        cal0,
        windows=windows,
        mean_sd=tuple(cal0.mean_sd[0] * (1 + 0.1 * i) for i in range(k)),
        logq_mean=tuple(cal0.logq_mean[0] for _ in range(k)),
        logq_sd=tuple(cal0.logq_sd[0] * (1 + 0.2 * i) for i in range(k)),
    )
    for r in _records()[:3]:
        np.testing.assert_array_equal(
            alarm_statistic(r, cal, raw=True, start=100), _old_statistic(r, cal, True, 100)
        )


def test_statistic_in_pieces_with_carried_sums_is_the_whole_pass() -> None:
    cal = calibrate(_residual(1, 40_000)[:6000], 25)
    for r in _records():
        n = r.shape[0]
        start = 5000
        want = alarm_statistic(r, cal, raw=True, start=start)
        out = np.full(n, -1.0)
        carry = np.zeros(4)
        lo = start
        for h in (5001, 5100, 5300, 9000, 20_000, n):
            got = alarm_statistic(r[:h], cal, raw=True, start=lo, out=out[:h], carry=carry)
            assert got.base is out or got is out
            lo = h
        np.testing.assert_array_equal(out[start:], want[start:])
        assert (out[:start] == -1.0).all()  # left alone before the start
        # a carry from further on than the next start is not used
        carry[0] = n
        np.testing.assert_array_equal(
            alarm_statistic(r, cal, raw=True, start=start, carry=carry)[start:], want[start:]
        )


def _short_cases() -> list[tuple[np.ndarray, np.ndarray]]:
    """Short records whose alarms come in bursts closer than the merging gap (an
    intermittent offset, a gain fault on a bursty structure), so that a stretch often
    ends between runs that merge, or inside a change-point search."""
    n = 12_000
    rng = np.random.default_rng(31)
    out = []
    for seed in range(4):
        ref = _structure(seed + 10, n)
        r = _residual(seed + 10, n)
        on = 4500 + 37 * seed
        for a in range(on, on + 2400, 150 + 20 * seed):  # bursts 150-210 samples apart
            r[a : a + 60] += 0.12
        r[8000 + 50 * seed :] += (0.5 + 0.2 * seed) * ref[8000 + 50 * seed :]
        r[rng.integers(4000, n, 30)] = np.nan
        out.append((r, ref))
    return out


@pytest.mark.parametrize("steps", [(0.37, 1), (0.11, 1), (1.3, 1)])
def test_diagnosis_with_stretches_ending_everywhere(
    steps: tuple[float, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(_Intervals, "FIRST_STEP", steps[0])
    monkeypatch.setattr(_Intervals, "GROWTH", steps[1])
    count = 0
    for r, ref in _short_cases():
        cal = calibrate(r[:4000], 25)
        ivs = detect(r, cal, search_start=4000)
        for iv in ivs:
            for start in (iv.onset, iv.onset - 5, iv.first_alarm):
                moved = Interval(start, iv.end, iv.first_alarm, iv.last_alarm, 2.0, 0.0)
                want = _whole_record_diagnosis(r, ref, cal, moved, RATE)
                assert diagnose_interval(r, ref, cal, moved, RATE) == want
                count += 1
    assert count >= 12


@pytest.mark.parametrize("steps", [(0.37, 1), (0.05, 2), (8.0, 8)])
def test_intervals_on_a_growing_stretch_are_the_whole_records(
    steps: tuple[float, int], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each question _Intervals answers (the i-th onset before a bound, whether the i-th
    interval ends after a sample), asked of a fresh search, against detect on the whole
    record."""
    monkeypatch.setattr(_Intervals, "FIRST_STEP", steps[0])
    monkeypatch.setattr(_Intervals, "GROWTH", steps[1])
    for r, _ in _short_cases()[:2]:
        n = r.shape[0]
        cal = calibrate(r[:4000], 25)
        for ss in (4000, 4400, 4520, 8030):
            stat = alarm_statistic(r, cal, raw=True, start=ss)
            full = detect(r, cal, search_start=ss)
            assert full
            for given in (None, stat):
                for i in range(len(full) + 1):
                    near = [] if i >= len(full) else [full[i].onset + 1, full[i].first_alarm]
                    for before in (ss, ss + 30, ss + 200, ss + 900, 8000, 9000, n, *near):
                        want = full[i].onset if i < len(full) else None
                        want = want if want is not None and want < before else None
                        lazy = _Intervals(r, n, cal, ss, given)
                        for j in range(i):
                            assert lazy.onset(j, n) == full[j].onset
                        assert lazy.onset(i, before) == want, (ss, i, before)
                    if i < len(full):
                        end = full[i].end
                        near = [] if end is None else [end - 1, end, end + 1]
                        for lo in (
                            full[i].onset,
                            full[i].onset + 50,
                            full[i].first_alarm + 400,
                            full[i].last_alarm - 1,
                            *near,
                        ):
                            lazy = _Intervals(r, n, cal, ss, given)
                            for j in range(i + 1):
                                lazy.onset(j, n)
                            assert lazy.ends_after(i, lo) == (end is None or end > lo)


@pytest.mark.parametrize("case", range(8))
def test_diagnosis_with_a_mapped_corrected_residual(
    case: int, tmp_path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """With a scratch directory the corrected residual moves to a memory-mapped buffer
    past MAPPED_CORRECTION samples: the same answers as in memory, and the faults that
    last to the end of the record do move."""
    import analyzer.diagnosis.events as events

    made = []

    def counted(*args, **kwargs):
        made.append(args[1])
        return events.buffer.__wrapped__(*args, **kwargs)

    counted.__wrapped__ = events.buffer  # type: ignore[attr-defined]
    monkeypatch.setattr(events, "MAPPED_CORRECTION", 2000)
    monkeypatch.setattr(events, "buffer", counted)
    name, r, ref = _cases()[case]
    start = 6000
    cal = calibrate(r[:start], 25)
    for iv in detect(r, cal, search_start=start):
        for reference in (ref, None):
            want = diagnose_interval(r, reference, cal, iv, RATE, 2.0)
            assert diagnose_interval(r, reference, cal, iv, RATE, 2.0, scratch=tmp_path) == want
    if case in (1, 3):  # the search went to the end of the record
        assert "corrected-residual" in made
    assert events_from_residual(
        "c", r, ref, cal, RATE, "d", search_start=start, scratch=tmp_path
    ) == events_from_residual("c", r, ref, cal, RATE, "d", search_start=start)


def test_mapped_corrected_residual_memory_is_set_by_its_limit(tmp_path) -> None:
    """A gain fault to the end of a long record: with a scratch directory the search for
    its end allocates memory set by its pieces, not by the record: 19 MB at 2, 4 and 8 M
    samples, against 24, 40 and 73 MB in memory (the corrected residual is 32 MB here)."""
    import tracemalloc

    n = 4_000_000
    ref = _structure(11, n)
    r = _residual(11, n)
    r[20_000:] += 0.8 * ref[20_000:]
    cal = calibrate(r[:6000], 25)
    iv = detect(r[:40_000], cal, search_start=6000)[0]
    iv = dataclasses.replace(iv, end=None)
    tracemalloc.start()
    try:
        got = diagnose_interval(r, ref, cal, iv, RATE, 2.0, scratch=tmp_path)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert got[1] is None  # lasts to the end: the search went through the record
    assert peak < 24e6, peak
    assert got == diagnose_interval(r, ref, cal, iv, RATE, 2.0)


@pytest.mark.parametrize("case", range(8))
def test_end_searches_from_the_detections_running_sums(
    case: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The end searches resume from the running sums detect kept along the residual
    (SumsIndex), not from the residual's first sample: the same answers, and the same
    statistic bit for bit from any start."""
    from analyzer.diagnosis import changes
    from analyzer.diagnosis import events as events_module

    monkeypatch.setattr(changes, "STAT_PIECE", 1500)  # many points along the record
    name, r, ref = _cases()[case]
    start = 6000
    cal = calibrate(r[:start], 25)
    index = changes.SumsIndex()
    ivs = detect(r, cal, search_start=start, index=index)
    assert len(index.points) > 10
    assert ivs == detect(r, cal, search_start=start)
    whole = alarm_statistic(r, cal, raw=True)
    for s in (start, 7777, 15_001, 39_000):
        carry = index.before(s, cal)
        assert 0 < carry[0] <= s - max(cal.windows) + 1
        got = alarm_statistic(r, cal, raw=True, start=s, carry=carry)
        assert np.array_equal(got[s:], whole[s:])
    for iv in ivs:
        for reference in (ref, None):
            want = diagnose_interval(r, reference, cal, iv, RATE, 2.0)
            assert diagnose_interval(r, reference, cal, iv, RATE, 2.0, index=index) == want

    class NoIndex(changes.SumsIndex):
        def before(self, start, cal):
            return np.zeros(4)

    with_index = events_from_residual("c", r, ref, cal, RATE, "d", search_start=start)
    monkeypatch.setattr(events_module, "SumsIndex", NoIndex)
    assert events_from_residual("c", r, ref, cal, RATE, "d", search_start=start) == with_index


@pytest.mark.parametrize(
    "case, magnitude, truth", [("gain ends", "gain", 1.6), ("slow drift", "rate_per_s", 0.0004)]
)
def test_a_shape_fitted_on_a_short_first_interval_is_refitted(
    case: str, magnitude: str, truth: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A fault whose alarm interval is short at first (a gain fault's interval after a
    quiet stretch, a slow drift's first alarms): the shape fitted on it alone is off
    (gain 1.46, rate 0.00034), and the corrected residual then alarms only after the
    fault ended (35 s and 2.6 s late). Refitted where the shape fails while the fault
    still shows, every interval's diagnosis has the fault's end (sample 30 000) and its
    size within 2 %; without refits it has not."""
    name, r, ref = next(c for c in _cases() if c[0] == case)
    cal = calibrate(r[:6000], 25)
    ivs = detect(r, cal, search_start=6000)

    def diagnoses() -> list[tuple[Classification, int | None]]:
        return [diagnose_interval(r, ref, cal, iv, RATE, 2.0) for iv in ivs]

    got = diagnoses()
    assert all(end == 30_000 for _, end in got), [end for _, end in got]
    assert all(c.magnitude[magnitude] == pytest.approx(truth, rel=0.02) for c, _ in got)
    monkeypatch.setattr("analyzer.diagnosis.events.MAX_REFITS", 0)
    # (a gain's end is also found past the raw alarms by _gain_ended, whatever its shape
    # was fitted on: without it too)
    monkeypatch.setattr("analyzer.diagnosis.events._gain_ended", lambda *_: None)
    assert any(end != 30_000 for _, end in diagnoses())


def _gain_fault(seed: int, gain: float) -> tuple[np.ndarray, np.ndarray]:
    """A residual ``measured - estimate`` whose sensor reads ``gain`` times the truth from
    sample 10 000 to 30 000, the estimate (reference) fault-free: the healthy residual's
    noise is scaled by the gain as well, not only the structure."""
    n = 40_000
    ref = _structure(seed, n)
    measured = ref + _residual(seed, n)
    measured[10_000:30_000] *= gain
    return measured - ref, ref


def test_a_gain_faults_end_is_searched_on_the_corrected_readings_residual(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A gain fault's residual is ``(a - 1) y_ref + a e``. Less the shape alone it is
    ``a e``, 1.44 times the healthy variance for a = 1.2: over a long interval the
    corrected residual alarms while the raw one still does, the shape is taken as not
    holding and the fault ends with its first alarms, before a quiet stretch (190.47 s).
    Divided by the gain (the residual of the corrected reading ``y / a``) it is the
    healthy ``e``: one event per record, from 100 s to the end at 300 s."""
    got, without = [], []
    for seed in range(1, 9):
        r, ref = _gain_fault(seed, 1.2)
        cal = calibrate(r[:6000], 25)
        events = events_from_residual("c", r, ref, cal, RATE, "d", search_start=6000, tau_corr=2.0)
        got.append([(e.type.value, e.onset_s, e.end_s, e.magnitude.get("gain")) for e in events])
        with monkeypatch.context() as m:
            m.setattr(Classification, "reading_gain", property(lambda self: 1.0))
            events = events_from_residual(
                "c", r, ref, cal, RATE, "d", search_start=6000, tau_corr=2.0
            )
            without.append([e.end_s for e in events])
    for events in got:
        assert len(events) == 1, got
        kind, onset, end, gain = events[0]
        assert kind == "multiplicative" and gain == pytest.approx(1.2, abs=0.01), got
        assert onset == pytest.approx(100.0, abs=0.1) and end == pytest.approx(300.0, abs=0.5)
    assert sum(190.47 in ends for ends in without) >= 3, without

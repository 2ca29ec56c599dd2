"""The alarm statistic computed only from a search's start, a statistic handed to
:func:`detect` instead of recomputed, and the search restricted to the span after its
start: each against the whole-record computation it replaces."""

import numpy as np
import pytest
from scipy import stats as sps
from scipy.signal import lfilter

from analyzer.diagnosis.changes import (
    Interval,
    _alarm_statistic_numpy,
    _runs,
    alarm_statistic,
    calibrate,
    change_point,
    detect,
)
from analyzer.diagnosis.events import diagnose_interval

RATE = 100.0


def _record(seed: int, n: int) -> np.ndarray:
    """A coloured healthy residual in channel units (offset 3, scale 0.5)."""
    e = np.random.default_rng(seed).standard_normal(n)
    return 3.0 + 0.5 * lfilter([1.0], [1.0, -0.6], e)


def _gappy_record() -> tuple[np.ndarray, int]:
    """Faults and gaps around a search start of 6000 (window 20, long window 160)."""
    r = _record(11, 20_000)
    r[4000:4500] += 1.0  # an alarm before the search start (must be ignored)
    r[5600:5760] = np.nan  # a gap longer than half the long window just before the start
    r[5950:6030] = np.nan  # a gap straddling the start
    r[5990:5993] = np.inf
    r[9000:12_000] += 0.6  # a fault, with a gap inside
    r[10_000:10_400] = np.nan
    r[15_000:] *= 1.8  # a gain change to the end
    return r, 6000


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_statistic_from_start_is_the_whole_record_pass_bit_for_bit(dtype: type) -> None:
    r, _ = _gappy_record()
    r = r.astype(dtype)
    cal = calibrate(r[:3000], 20)
    full = alarm_statistic(r, cal, raw=True)
    n = r.shape[0]
    starts = [0, 1, 19, 20, 159, 160, 161, 5599, 5600, 5700, 5760, 5761, 5950, 5990, 6000]
    for start in [*starts, 6030, 6100, 10_000, n - 1, n, n + 7]:
        part = alarm_statistic(r, cal, raw=True, start=start)
        assert part.shape == full.shape
        assert not part[:start].any(), start
        np.testing.assert_array_equal(part[start:], full[start:], err_msg=str(start))
    # standardized input too, and the whole pass still equals the numpy moving means
    z = cal.standardize(r)
    np.testing.assert_array_equal(
        alarm_statistic(z, cal, start=6000)[6000:], alarm_statistic(z, cal)[6000:]
    )
    np.testing.assert_allclose(full, _alarm_statistic_numpy(z, cal), rtol=1e-9, atol=1e-9)
    assert (full[6000:] > 1.0).any() and (full[:6000] > 1.0).any()


def test_mostly_gap_and_short_windows_near_the_start() -> None:
    """A start inside the first long window: windows not yet complete stay 0 for the
    long length (as in the whole pass), never look complete because of the start."""
    r = _record(5, 2_000)
    r[:400] += 2.0  # both statistics alarm from the first samples on
    r[100:180] = np.nan
    cal = calibrate(_record(6, 4_000), 20)
    full = alarm_statistic(r, cal, raw=True)
    ref = _alarm_statistic_numpy(cal.standardize(r), cal)
    for start in (0, 5, 19, 50, 100, 150, 159, 170, 250):
        part = alarm_statistic(r, cal, raw=True, start=start)
        np.testing.assert_array_equal(part[start:], full[start:])
        np.testing.assert_allclose(part[start:], ref[start:], rtol=1e-11, atol=1e-11)


def test_log_bound_holds() -> None:
    """The bound that lets the kernel skip a log: log(1 + u) <= u (6 + u) / (6 + 4 u)."""
    u = np.concatenate(([0.0], np.logspace(-12, 150, 20_000)))
    bound = u * (6.0 + u) / (6.0 + 4.0 * u)
    assert (np.log1p(u) <= bound * (1.0 + 1e-12) + 1e-15).all()


def test_statistic_where_the_log_mean_square_wins() -> None:
    """Gain changes and an erratic stretch (the log-mean-square statistic competes with
    the window mean at many samples): the kernel, which skips logs that cannot win, gives
    the numpy moving means' values."""
    r = _record(8, 30_000)
    r[5000:12_000] = 3.0 + (r[5000:12_000] - 3.0) * 1.3
    r[15_000:16_000] += np.random.default_rng(1).standard_normal(1000) * 2.0
    r[20_000:] = 3.0 + (r[20_000:] - 3.0) * 0.6 + 0.05
    cal = calibrate(r[:4000], 25)
    got = alarm_statistic(r, cal, raw=True)
    want = _alarm_statistic_numpy(cal.standardize(r), cal)
    np.testing.assert_allclose(got, want, rtol=1e-11, atol=1e-11)


def test_runs_equal_the_diff_definition() -> None:
    rng = np.random.default_rng(3)
    masks = [np.zeros(0, bool), np.zeros(5, bool), np.ones(5, bool), np.array([True])]
    masks += [rng.random(n) < p for n in (1, 2, 50, 1000) for p in (0.1, 0.5, 0.9)]
    for mask in masks:
        d = np.diff(np.concatenate(([0], mask.astype(np.int8), [0])))
        want = list(
            zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True)
        )
        assert _runs(mask) == want
        assert _runs(mask, 17) == [(a + 17, b + 17) for a, b in want]


def _reference_detect(residual: np.ndarray, cal, search_start: int) -> list[Interval]:
    """:func:`detect` as it was: the whole record's statistic with the alarms before the
    start zeroed, runs and observed-sample counts over the whole record."""
    n = residual.shape[0]
    w, wl = cal.window, cal.long_window
    s = alarm_statistic(residual, cal, raw=True)
    s[:search_start] = 0.0
    d = np.diff(np.concatenate(([0], (s > 1.0).astype(np.int8), [0])))
    runs = zip(np.flatnonzero(d == 1).tolist(), np.flatnonzero(d == -1).tolist(), strict=True)
    seen = np.concatenate(([0], np.cumsum(np.isfinite(residual), dtype=np.int64)))
    merged: list[list[int]] = []
    for a, b in runs:
        if merged and seen[a] - seen[merged[-1][1]] <= wl:
            merged[-1][1] = b
        else:
            merged.append([a, b])
    n_windows = max(1.0, n / w) * len(cal.windows)
    out, prev_end = [], search_start
    for a, b in merged:
        peak = float(np.max(s[a:b]))
        p = float(min(1.0, 2.0 * sps.norm.sf(peak * cal.z_crit) * n_windows))
        lo, hi = max(prev_end, a - wl - 2 * w), min(n, a + w)
        onset = lo + change_point(cal.standardize(residual[lo:hi])) if hi - lo > 4 else a
        onset = min(onset, a)
        end = None
        if b < n - 1:
            lo2, hi2 = max(onset + 1, b - 1 - wl - 2 * w), min(n, b - 1 + w)
            seg = cal.standardize(residual[lo2:hi2])
            end = lo2 + change_point(seg, before_normal=False) if hi2 - lo2 > 4 else b
            end = max(end, onset + 1)
        out.append(Interval(onset, end, a, b - 1, peak, p))
        prev_end = end if end is not None else n
    return out


def test_detect_equals_the_whole_record_reference() -> None:
    r, start = _gappy_record()
    cal = calibrate(r[:3000], 20)
    # a fault interrupted by a gap longer than the long window: one interval (the gap's
    # samples are not observed), and alarms just before the start are cut at it
    r2 = _record(12, 20_000)
    r2[5900:7000] += 1.0
    r2[8000:8300] += 1.0
    r2[7200:8000] = np.nan
    for rec, ss in ((r, start), (r, 0), (r, 9500), (r, 19_990), (r2, 6000), (r2, 7100)):
        want = _reference_detect(rec, cal, ss)
        assert detect(rec, cal, search_start=ss) == want, ss
        # the whole record's statistic handed in (alarms before the start included)
        full = alarm_statistic(rec, cal, raw=True)
        assert detect(rec, cal, search_start=ss, statistic=full) == want, ss
        assert not np.isnan(full).any()
    assert len(_reference_detect(r, cal, start)) >= 2
    assert len(_reference_detect(r2, cal, 6000)) == 1


def test_diagnose_interval_with_the_callers_statistic() -> None:
    """The residual's statistic from the caller gives the end and classification that
    the statistic computed in diagnose_interval gives."""
    rng = np.random.default_rng(21)
    n = 60_000
    ref = lfilter([1.0], [1.0, -1.95, 0.96], rng.standard_normal(n)) * 0.05
    r = 0.02 * lfilter([1.0], [1.0, -0.6], rng.standard_normal(n))
    r[30_000:45_000] += 0.4 * ref[30_000:45_000]  # a gain fault that ends
    r[20_000:20_300] = np.nan
    start = 6000
    cal = calibrate(r[:start], 25)
    stat = alarm_statistic(r, cal, raw=True, start=start)
    ivs = detect(r, cal, search_start=start, statistic=stat)
    assert ivs
    for iv in ivs:
        want = diagnose_interval(r, ref, cal, iv, RATE)
        assert diagnose_interval(r, ref, cal, iv, RATE, statistic=stat) == want


@pytest.mark.parametrize("rate", [1e-9, 1e-6, 1e-3, 0.1, 0.49])
def test_z_crit_is_the_normal_quantile(rate: float) -> None:
    cal = calibrate(_record(2, 5_000), 20, rate)
    assert cal.z_crit == float(sps.norm.isf(rate / (2.0 * len(cal.windows)) / 2.0))

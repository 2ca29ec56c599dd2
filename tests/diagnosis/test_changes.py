import numpy as np
import pytest
from scipy.signal import lfilter

from analyzer.diagnosis import calibrate, change_point, detect
from analyzer.errors import DetectorError


def _noise(seed, n, phi=0.0):
    e = np.random.default_rng(seed).normal(size=n)
    return lfilter([1.0], [1.0, -phi], e) if phi else e


@pytest.mark.parametrize("phi", [0.0, 0.8])
def test_false_alarm_rate_is_respected(phi):
    # 20 records x 200 000 samples at a per-sample rate of 1e-6: about 4 alarms expected
    # if the Gaussian calibration were exact; more than 20 would mean it is not honest.
    alarms = 0
    for seed in range(20):
        r = _noise(seed, 200_000, phi)
        cal = calibrate(r[:3000], 50, 1e-6)
        alarms += len(detect(r, cal, search_start=3000))
    assert alarms <= 20


def test_offset_is_detected_with_onset_and_end():
    r = _noise(1, 20_000)
    r[9000:14000] += 1.0
    cal = calibrate(r[:3000], 50)
    (iv,) = detect(r, cal, search_start=3000)
    assert abs(iv.onset - 9000) <= 25
    assert iv.end is not None and abs(iv.end - 14000) <= 50
    assert iv.p_value < 1e-6


def test_fault_lasting_to_the_end_has_no_end():
    r = _noise(2, 10_000)
    r[7000:] += 2.0
    cal = calibrate(r[:3000], 50)
    (iv,) = detect(r, cal, search_start=3000)
    assert iv.end is None


def test_change_point_finds_variance_change():
    x = _noise(3, 2000)
    x[1200:] *= 3.0
    assert abs(change_point(x) - 1200) <= 15


def test_change_point_end_of_fault():
    x = _noise(4, 2000)
    x[:800] += 2.5
    assert abs(change_point(x, before_normal=False) - 800) <= 10


def _step(n: int, start: int, stop: int, level: float, wobble: float) -> np.ndarray:
    """No noise: a healthy part of exactly unit variance (+1, -1, +1, ...: the N(0, 1)
    the change point's likelihood expects; all zeros would fit the changed part's
    N(mu, v) better, v going to 0), and ``level`` with a ``wobble`` of alternating sign in
    ``[start, stop)``."""
    x = (-1.0) ** np.arange(n)
    x[start:stop] = level + wobble * (-1.0) ** np.arange(stop - start)
    return x


@pytest.mark.parametrize("wobble", [0.0, 0.5, 1.0])
@pytest.mark.parametrize("level", [4.0, -3.0, -10.0])
@pytest.mark.parametrize("at", [20, 21, 37, 100, 163, 180])
def test_change_point_of_a_noiseless_step_is_its_exact_sample(at, level, wobble):
    """The first changed sample (the onset) and the first healthy one (the end), to the
    sample: a step has no noise to hide it behind (test audit ux65 C6: an end one sample
    late passed the +-10-sample test above and was caught once, by accident)."""
    n = 200
    assert change_point(_step(n, at, n, level, wobble)) == at
    assert change_point(_step(n, 0, at, level, wobble), before_normal=False) == at
    # a fault between healthy stretches, each end searched on its side
    fault = _step(n, at // 2, at, level, wobble)
    assert change_point(fault[: at - 2]) == at // 2
    assert change_point(fault[at // 2 + 3 :], before_normal=False) == at - (at // 2 + 3)


def test_calibration_needs_enough_samples():
    with pytest.raises(DetectorError, match="too little healthy data"):
        calibrate(np.random.default_rng(0).normal(size=100), 50)


def test_calibration_refuses_constant_residual():
    with pytest.raises(DetectorError, match="constant"):
        calibrate(np.ones(5000), 50)


def test_calibration_refuses_bad_false_alarm_rate():
    with pytest.raises(DetectorError, match="false_alarm_rate"):
        calibrate(np.random.default_rng(0).normal(size=5000), 50, 0.7)


@pytest.mark.parametrize("n", [10, 199, 5_000])
def test_compiled_alarm_statistic_equals_the_numpy_moving_means(n: int) -> None:
    """The one-pass kernel (ring buffer of prefix sums) gives the statistic of the
    numpy moving means, gaps included, standardized or in channel units."""
    from analyzer.diagnosis.changes import _alarm_statistic_numpy, alarm_statistic

    rng = np.random.default_rng(n)
    healthy = 3.0 + 2.0 * rng.standard_normal(4_000)
    cal = calibrate(healthy, 20)
    r = 3.0 + 2.0 * rng.standard_normal(n)
    r[n // 3 :] += 1.5  # an offset: alarms
    r[n // 5 : n // 5 + 90] = np.nan  # a gap longer than half the long window
    r[n // 2 : n // 2 + 7] = np.inf
    z = cal.standardize(r)
    expected = _alarm_statistic_numpy(z, cal)
    np.testing.assert_allclose(alarm_statistic(z, cal), expected, rtol=1e-11, atol=1e-11)
    np.testing.assert_allclose(alarm_statistic(r, cal, raw=True), expected, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(
        alarm_statistic(r.astype(np.float32), cal, raw=True),
        _alarm_statistic_numpy(cal.standardize(r.astype(np.float32)), cal),
        rtol=1e-9,
        atol=1e-9,
    )
    if n > 1_000:
        assert (expected > 1.0).any() and (expected[: n // 5] <= 1.0).all()


def test_a_gap_in_the_data_does_not_end_a_fault(tmp_path):
    """The bundled gain-fault sample (s4 x 1.5 from 16 s) with its middle third lost (a
    damaged file): one finding lasting to the end, not one that ends where the data stops
    at 20 s."""
    import gzip
    from pathlib import Path

    from analyzer.pipeline import RunOptions, analyze
    from analyzer.types import FaultType

    sample = Path(__file__).resolve().parents[2] / "samples" / "building_multiplicative.csv.gz"
    header, *rows = gzip.decompress(sample.read_bytes()).decode().splitlines()
    assert len(rows) == 12000  # 60 s at 200 Hz
    folder = tmp_path / "archive"
    folder.mkdir()
    (folder / "part0.csv").write_text("\n".join([header, *rows[:4000]]) + "\n")
    (folder / "part1.csv").write_bytes(b"\x00\xff" * 8)  # the damaged middle file
    (folder / "part2.csv").write_text("\n".join([header, *rows[8000:]]) + "\n")
    analysis = analyze([folder], RunOptions())
    assert any(i.errors for i in analysis.inputs)
    (f,) = analysis.findings
    assert f.channel == "s4" and f.type is FaultType.MULTIPLICATIVE
    assert f.end_s is None and f.onset_s == pytest.approx(16.0, abs=0.3)
    assert f.magnitude["gain"] == pytest.approx(1.5, rel=0.1)


def _faulty_record(n: int, seed: int) -> tuple[np.ndarray, object]:
    """A coloured residual with offsets, a gain change and gaps, and its calibration."""
    rng = np.random.default_rng(seed)
    cal = calibrate(lfilter([1.0], [1.0, -0.6], rng.standard_normal(20_000)), 40)
    r = lfilter([1.0], [1.0, -0.6], rng.standard_normal(n))
    for k in range(5):  # short offsets, some closer than the long window
        a = n // 7 * (k + 1) + int(rng.integers(0, 500))
        r[a : a + int(rng.integers(50, 900))] += 3.0
    r[n // 2 :] *= 1.0 + 0.8 * (np.arange(n - n // 2) > n // 4)  # a gain change to the end
    r[n // 3 : n // 3 + 700] = np.nan  # a gap longer than the long window
    r[n // 4 : n // 4 + 30] = np.inf
    return r, cal


@pytest.mark.parametrize("piece", [1_000, 4_096, 1 << 18])
def test_detect_in_pieces_equals_detect_on_the_whole_statistic(monkeypatch, piece):
    """detect without a statistic computes it a piece at a time: the same intervals (every
    field) as detect given the whole-record statistic, with alarm runs, merges and gaps
    across the pieces' edges."""
    from analyzer.diagnosis import changes

    n = 200_000
    r, cal = _faulty_record(n, piece)
    start = 7_000
    whole = changes.alarm_statistic(r, cal, raw=True, start=start)
    want = changes.detect(r, cal, search_start=start, statistic=whole)
    assert len(want) >= 4
    monkeypatch.setattr(changes, "STAT_PIECE", piece)
    got = changes.detect(r, cal, search_start=start)
    assert got == want
    counts = []
    for gap in (10, 20_000, 60_000):  # runs merged over observed gaps of up to gap samples
        want = changes.detect(r, cal, search_start=start, min_gap=gap, statistic=whole)
        assert changes.detect(r, cal, search_start=start, min_gap=gap) == want
        counts.append(len(want))
    assert counts[0] > counts[1] > counts[2] >= 1
    assert changes.detect(r[:start], cal, search_start=start) == []


def test_alarm_statistic_into_a_piece_of_its_own_length():
    """``base``: the statistic of samples base.. written from out[0]; bit for bit the
    whole-record pass's, and a base after the start is refused."""
    from analyzer.diagnosis.changes import alarm_statistic

    r, cal = _faulty_record(30_000, 1)
    whole = alarm_statistic(r, cal, raw=True)
    out = np.full(5_000, -1.0)
    got = alarm_statistic(r[:20_000], cal, raw=True, start=15_000, out=out, base=15_000)
    assert got is out
    np.testing.assert_array_equal(out, whole[15_000:20_000])
    np.testing.assert_array_equal(
        alarm_statistic(r, cal, raw=True, start=12_000, base=10_000)[2_000:], whole[12_000:]
    )
    with pytest.raises(ValueError, match="base"):
        alarm_statistic(r, cal, raw=True, start=10, base=11)


def test_observed_above_counts_only_finite_samples():
    from analyzer.diagnosis.changes import _observed_above

    x = np.ones(300_000)
    x[1_000:250_000] = np.nan
    for lo, hi, limit in [
        (0, 300_000, 50_999),
        (0, 300_000, 51_000),
        (500, 260_000, 10_499),
        (500, 260_000, 10_500),
        (2_000, 240_000, 0),
        (0, 10, 10),
    ]:
        assert _observed_above(x, lo, hi, limit) == (np.isfinite(x[lo:hi]).sum() > limit)


def test_detect_memory_does_not_grow_with_the_record():
    """The alarm search over a long record holds a piece of the statistic, not the whole
    of it: numpy's allocations during detect (traced) stay a few MB on a 4 M-sample
    record (a whole-record statistic alone would be 32 MB), and so do those of the
    search for a fault's end on the raw residual (diagnose_interval's _Intervals), which
    grows its stretch to the end of the record here."""
    import tracemalloc

    from analyzer.diagnosis.events import _Intervals

    rng = np.random.default_rng(5)
    cal = calibrate(rng.standard_normal(20_000), 40, 1e-9)  # no false alarm in 4 M samples
    n = 4_000_000
    r = rng.standard_normal(n)
    r[3_000_000:3_000_400] += 3.0  # one short fault
    tracemalloc.start()
    try:
        found = detect(r, cal, search_start=10_000)
        _, peak = tracemalloc.get_traced_memory()
        tracemalloc.reset_peak()
        later = _Intervals(r, n, cal, 2_000_000)
        assert later.onset(1, n) is None  # searched to the record's end
        _, peak_end = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert [iv.first_alarm // 1000 for iv in found] == [3_000]
    assert later.h == n and [iv.first_alarm // 1000 for iv in later.found] == [3_000]
    assert later.found == found
    assert peak < 6e6, peak
    assert peak_end < 6e6, peak_end

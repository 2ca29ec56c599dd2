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

"""An ``other`` fault ends where its residual last left the healthy band when the
residual is quiet after it: a one-sample spike is one sample long, not the length of the
alarm statistic's long window; a noise burst keeps its alarms' end."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from analyzer.diagnosis.changes import calibrate
from analyzer.diagnosis.events import events_from_residual
from analyzer.types import FaultType

RATE = 100.0
START = 6000


def _residual(seed: int, n: int = 20_000) -> np.ndarray:
    e = np.random.default_rng(seed).standard_normal(n)
    return 0.05 * lfilter([1.0], [1.0, -0.6], e)


@pytest.mark.parametrize("seed", [1, 2, 3])
@pytest.mark.parametrize("size", [30.0, -60.0])
def test_a_one_sample_spike_is_one_sample_long(seed: int, size: float) -> None:
    r = _residual(seed)
    sd = float(np.std(r[:START]))
    at = 11_234
    r[at] += size * sd
    cal = calibrate(r[:START], 25)
    events = events_from_residual("s1", r, None, cal, RATE, "test", search_start=START)
    assert len(events) == 1
    (ev,) = events
    assert ev.type is FaultType.OTHER
    # the change point may put the onset a sample or two before the spike
    assert at / RATE - 3.5 / RATE <= ev.onset_s <= at / RATE
    assert ev.end_s == pytest.approx((at + 1) / RATE)
    # the spike's own size, not 1 s of healthy residual averaged in
    assert abs(ev.magnitude["rms"]) == pytest.approx(abs(size) * sd, rel=0.1)
    assert ev.magnitude["offset"] == pytest.approx(size * sd, rel=0.1)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_noise_burst_keeps_the_end_of_its_alarms(seed: int) -> None:
    """A stretch of raised noise: its last large sample comes before its end, and the
    residual after that sample is not healthy, so the fault is not cut there."""
    r = _residual(seed)
    sd = float(np.std(r[:START]))
    burst = np.random.default_rng(seed + 50).standard_normal(300) * 3.0 * sd
    r[10_000:10_300] += burst
    cal = calibrate(r[:START], 25)
    events = events_from_residual("s1", r, None, cal, RATE, "test", search_start=START)
    assert events
    first, last = events[0], events[-1]
    assert first.onset_s == pytest.approx(100.0, abs=0.3)
    assert last.end_s is not None and last.end_s >= 102.8


@pytest.mark.parametrize("seed", [1, 2, 4])
@pytest.mark.parametrize("size", [7.0, 50.0])
def test_a_doublet_ends_at_its_last_sample_past_the_per_sample_threshold(
    seed: int, size: float
) -> None:
    """Two samples of ``+size`` and ``-size`` sd on white noise: the fault ends one sample
    after the second, for a doublet just past the per-sample threshold (7 sd against
    ``z_crit`` = 5.16, the normal quantile of the false-alarm rate) as for a large one,
    and its rms is the doublet's, ``size`` sd to the noise's 1 sd. Judged against twice
    ``z_crit`` (10.3 sd) instead, the 7-sd doublet kept the alarms' end, two samples
    later, and an rms of 5 sd. (A single 7-sd sample is below what the windowed
    statistics detect, hence two.)"""
    r = 0.05 * np.random.default_rng(seed).standard_normal(20_000)
    cal = calibrate(r[:START], 25)
    assert 5.0 < cal.z_crit < 7.0 - 1.5  # 7 sd is past it by more than the noise moves it
    at = 11_234
    r[at : at + 2] += size * cal.std * np.array([1.0, -1.0])
    events = events_from_residual("s1", r, None, cal, RATE, "test", search_start=START)
    (ev,) = events
    assert ev.type is FaultType.OTHER
    assert ev.onset_s == pytest.approx(at / RATE)
    assert ev.end_s == pytest.approx((at + 2) / RATE)
    assert ev.magnitude["rms"] == pytest.approx(size * cal.std, rel=0.15)

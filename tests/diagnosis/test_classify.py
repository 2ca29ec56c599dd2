import numpy as np
import pytest

from analyzer.diagnosis import classify, correlation_time
from analyzer.types import FaultType

RATE = 200.0


@pytest.fixture
def signal():
    t = np.arange(4000) / RATE
    rng = np.random.default_rng(0)
    ref = 3.0 * np.sin(2 * np.pi * 1.3 * t) + 1.5 * np.sin(2 * np.pi * 4.1 * t + 1.0)
    return t, ref, rng.normal(scale=0.3, size=t.shape)


def test_additive(signal):
    t, ref, noise = signal
    c = classify(1.2 + noise, ref, 0.3, RATE)
    assert c.type is FaultType.ADDITIVE
    assert c.magnitude["offset"] == pytest.approx(1.2, abs=0.03)
    assert c.confidence > 0.9


def test_multiplicative(signal):
    t, ref, noise = signal
    c = classify(0.5 * ref + noise, ref, 0.3, RATE)
    assert c.type is FaultType.MULTIPLICATIVE
    assert c.magnitude["gain"] == pytest.approx(1.5, abs=0.02)


def test_dead_sensor_is_gain_zero(signal):
    t, ref, noise = signal
    c = classify(-ref + noise, ref, 0.3, RATE)
    assert c.type is FaultType.MULTIPLICATIVE
    assert c.magnitude["gain"] == pytest.approx(0.0, abs=0.02)


def test_drift_with_back_extrapolated_onset(signal):
    t, ref, noise = signal
    # the drift began 0.5 s before the stretch handed to the classifier
    c = classify(0.4 * (t + 0.5) + noise, ref, 0.3, RATE)
    assert c.type is FaultType.DRIFT
    assert c.magnitude["rate_per_s"] == pytest.approx(0.4, rel=0.03)
    assert c.onset_shift_s == pytest.approx(-0.5, abs=0.1)


def test_erratic_is_other(signal):
    t, ref, noise = signal
    erratic = np.random.default_rng(9).standard_t(2, size=t.shape) * 2.0
    c = classify(erratic, ref, 0.3, RATE)
    assert c.type is FaultType.OTHER


def test_correlation_time():
    rng = np.random.default_rng(1)
    white = rng.normal(size=20000)
    assert correlation_time(white) < 1.3
    from scipy.signal import lfilter

    ar = lfilter([1], [1, -0.9], white)
    # integrated autocorrelation time of AR(1): (1 + phi) / (1 - phi) = 19
    assert 12 < correlation_time(ar) < 26


def test_a_shape_traced_back_into_the_healthy_window_starts_at_its_end():
    """A drift traced back to zero before the end of the healthy window: the onset is the
    window's end (the analysis takes the window as fault-free), with less confidence and
    the traced onset kept as evidence; otherwise the traced onset stands."""
    from types import SimpleNamespace

    from analyzer.diagnosis.events import EARLY_ONSET_FACTOR, bounded_onset

    drift = SimpleNamespace(onset_shift_s=-30.0)
    onset, factor, ev = bounded_onset(4000, drift, 100.0, 2000)  # 40 s - 30 s < 20 s
    assert onset == 20.0 and factor == EARLY_ONSET_FACTOR
    assert ev == {"traced_onset_s": 10.0, "starts_in_training": True}
    onset, factor, ev = bounded_onset(6000, drift, 100.0, 2000)  # 60 s - 30 s
    assert (onset, factor, ev) == (30.0, 1.0, {})

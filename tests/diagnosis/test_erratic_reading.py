"""A sensor giving random data uncorrelated with its signal is an erratic fault
(``other``), not a gain near 0 (ux57 item 1b: Li et al.'s sensor 1 read "gain x-0.09331:
reads 9.33 % of its signal, inverted, nearly dead"); a nearly dead or dead sensor stays a
gain (:func:`analyzer.diagnosis.classify._erratic_reading`)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.error_function import ErrorFunction
from analyzer.diagnosis import classify
from analyzer.simulate_mdof import chain_archive
from analyzer.types import FaultType

RATE = 200.0
N = 2000


def _reference(seed: int) -> tuple[np.ndarray, np.random.Generator]:
    """A fault-free estimate 10 times the healthy residual's spread (sigma = 1)."""
    t = np.arange(N) / RATE
    rng = np.random.default_rng(seed)
    y = 10.0 * np.sin(2 * np.pi * 1.3 * t) + 7.0 * np.sin(2 * np.pi * 3.7 * t + 1.0)
    return y * 10.0 / float(np.std(y)), rng


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("rms", [0.5, 0.8, 1.0])
def test_random_data_in_place_of_the_reading_is_other(seed: int, rms: float) -> None:
    """The reading replaced by white noise of ``rms`` times the signal's spread: the
    least-squares gain is near 0 and its shape (``-y``) explains most of the fault
    signal's energy (1 / (1 + rms^2): 0.5-0.8), but almost none of the reading's."""
    y, rng = _reference(seed)
    reading = rms * 10.0 * rng.standard_normal(N)
    c = classify(reading - y, y, 1.0, RATE)
    assert c.type is FaultType.OTHER, (c.type, c.magnitude, c.explained)
    assert c.explained < 0.5
    assert c.params["reading_explained"] == c.explained


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize("gain", [0.0, 0.03, 0.05, 0.5])
def test_a_sensor_that_shrinks_its_reading_stays_a_gain(seed: int, gain: float) -> None:
    """Readings shrunk to ``gain`` of the signal, the reading's own noise (healthy size,
    scaled with it) added: a gain (dead at 0), as before."""
    y, rng = _reference(seed)
    reading = gain * (y + rng.standard_normal(N))
    c = classify(reading - y, y, 1.0, RATE)
    assert c.type is FaultType.MULTIPLICATIVE, (c.type, c.magnitude, c.explained)
    assert c.magnitude["gain"] == pytest.approx(gain, abs=0.02)


def test_a_dead_sensor_with_its_noise_left_stays_a_gain() -> None:
    """A dead sensor whose reading keeps noise of the healthy residual's size: gain 0."""
    y, rng = _reference(3)
    c = classify(rng.standard_normal(N) - y, y, 1.0, RATE)
    assert c.type is FaultType.MULTIPLICATIVE
    assert c.magnitude["gain"] == pytest.approx(0.0, abs=0.02)


@pytest.mark.parametrize("approach", ["indirect", "direct"])
@pytest.mark.parametrize("seed", [0, 1])
def test_paper_example_random_data_is_other_dead_sensor_a_gain(approach: str, seed: int) -> None:
    """Li et al. 2007's example (1 % noise, the 0.1 s window that keeps its four failures
    apart): sensor 1's random data (2-4 s, 6-8 s) is ``other`` at both failures, sensor 2's
    zero reading (4-6 s, 8-10 s) a gain near 0. Before, sensor 1 read gains of -0.09 to
    0.13 (20 of 20 failures on seeds 0-4, both approaches)."""
    arch = chain_archive(noise=0.01, seed=seed)
    data = Dataset(arch.values, arch.channels, arch.rate_hz, arch.train)
    ctx = RunContext(config=arch.config, explicit=True)
    det = ErrorFunction(approach=approach, window=int(0.1 * arch.rate_hz))
    res = det.run(det.fit(data, ctx), data, ctx)
    s1 = [e for e in res.events if e.channel == "s1"]
    s2 = [e for e in res.events if e.channel == "s2"]
    assert len(s1) == 2 and len(s2) == 2, [(e.channel, e.onset_s) for e in res.events]
    for e in s1:
        assert e.type is FaultType.OTHER, (e.onset_s, e.type, e.magnitude)
    for e in s2:
        assert e.type is FaultType.MULTIPLICATIVE, (e.onset_s, e.type, e.magnitude)
        assert abs(e.magnitude["gain"]) < 0.1

"""The response level of a record's channels against the healthy window's range
(:mod:`analyzer.diagnosis.load`)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.diagnosis.load import LoadGuard, load_range, load_ratio
from analyzer.simulate import simulate_building

RATE_HZ = 200.0
TRAIN = (0, 2400)  # the default window of 60 s: its first 20 %


def test_the_level_is_the_other_channels_not_the_sensors_own():
    """A record whose every channel is 3 times as loud from its middle has 9 times the
    unchanged record's level there (a variance), and at most 1 inside the window; with a
    gain of 3 on one channel alone, the level without it is the unchanged record's."""
    _, y, names = simulate_building(5, 60.0, RATE_HZ, seed=1)
    louder = y.copy()
    louder[6000:] *= 3.0
    rng = load_range(louder, TRAIN, RATE_HZ)
    others = [1, 2, 3, 4]
    assert load_ratio(rng, louder, others, 0, TRAIN[1]) <= 1.0
    whole = load_ratio(rng, louder, others, 6400, 12000)
    plain = load_ratio(load_range(y, TRAIN, RATE_HZ), y, others, 6400, 12000)
    assert whole == pytest.approx(9.0 * plain, rel=0.05)
    gained = y.copy()
    gained[6000:, 0] *= 3.0
    guard = LoadGuard(gained, TRAIN, RATE_HZ, healthy=True)
    assert guard(range(5), 0, 6400, 12000) == pytest.approx(plain)
    assert LoadGuard(gained, TRAIN, RATE_HZ, healthy=False)(range(5), 0, 6000, 12000) == 0.0


@pytest.mark.parametrize(
    ("offset", "sd"), [(1e6, 1.0), (1e6, 1e-3), (47.123456, 1e-7), (1.7e9, 1.0)]
)
def test_a_channel_far_from_zero_is_no_louder_than_the_same_channel_centred(offset, sd):
    """Stationary channels at a large offset (a pressure in pascals, a latitude, a
    timestamp-like count) have the level of the same channels at zero: the running sums
    the variance comes from must not round their spread away (raw sums read them 2.3-3.5
    times the healthy window's loudest after it)."""
    rate, n, train = 100.0, 360_000, (0, 72_000)
    base = np.random.default_rng(0).standard_normal((n, 3))
    centred = load_ratio(load_range(base, train, rate), base, [0, 1, 2], train[1], n)
    y = offset + sd * base
    level = load_ratio(load_range(y, train, rate), y, [0, 1, 2], train[1], n)
    assert centred < 1.0
    assert level == pytest.approx(centred, rel=0.02)

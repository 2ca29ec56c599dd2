"""Channels sampled at irregular times (exponential, gamma or uniform intervals) are
aligned on nearly every tick; their outages, and a regular channel's, stay gaps."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.readers.base import ChannelChunk
from analyzer.store import GAP_FACTOR, ChannelStore

NS = 1_000_000_000

CHANCE = 1e-4
"""Share of exponential steps allowed to be gaps: a silence longer than the 11.5 mean
steps bridged comes by chance once in e**11.5 = 1e5 steps."""


def _store(t: np.ndarray, v: np.ndarray, **kw: object) -> ChannelStore:
    chunks = (
        ChannelChunk("a", t[s : s + 50_000], v[s : s + 50_000]) for s in range(0, t.size, 50_000)
    )
    return ChannelStore.from_chunks(chunks, **kw)  # type: ignore[arg-type]


def _times(steps_s: np.ndarray) -> np.ndarray:
    return np.round(np.cumsum(steps_s) * NS).astype(np.int64)


def _wave(t: np.ndarray, hz: float) -> np.ndarray:
    return np.sin(2 * np.pi * hz * t / NS)


@pytest.mark.parametrize(("mean_s", "seed"), [(0.002, 1), (0.01, 2), (0.05, 3)])
def test_exponential_intervals_give_a_value_on_every_tick(mean_s, seed):
    """Poisson sampling: the median step is 0.69 of the mean and a fifth of the steps
    exceed 2.5 median steps, which were all gaps (with the clock at 1 / median, 1.5
    times the samples' rate). The rate is the mean rate; a step is a gap only by the
    chance of a long silence (:data:`CHANCE`)."""
    rng = np.random.default_rng(seed)
    t = _times(rng.exponential(mean_s, 20_000))
    hz = 0.02 / mean_s  # 50 samples per cycle on average
    with _store(t, _wave(t, hz)) as store:
        info = store.info("a")
        assert info.irregular
        assert info.rate_hz == pytest.approx(1 / mean_s, rel=0.03)
        assert info.gaps <= CHANCE * t.size
        al = store.align(["a"])
        x = al.materialize()[:, 0]
        assert al.rate_hz == pytest.approx(info.rate_hz, rel=1e-3)
        assert np.isnan(x).mean() <= 20 * CHANCE  # a gap: up to 11.5 mean steps
        err = np.abs(x - _wave(al.times_ns(), hz))
        assert np.nanquantile(err, 0.99) < 0.05
        np.testing.assert_array_equal(al.block(0, al.n)[:, 0], x)


@pytest.mark.parametrize("lost", [20, 200])
def test_an_outage_of_an_irregular_channel_stays_a_gap(lost):
    """A stretch without samples for ``lost`` mean steps (the longest ordinary step of
    exponential steps is their 99th percentile, 4.6 mean steps: 11.5 are bridged) is
    a gap, and only it."""
    rng = np.random.default_rng(lost)
    mean = 0.01
    t = _times(rng.exponential(mean, 12_000))
    a = int(np.searchsorted(t, 50 * NS))
    t[a:] += int(lost * mean * NS)  # nothing from 50 s to 50 s + lost mean steps
    with _store(t, _wave(t, 1.0)) as store:
        info = store.info("a")
        assert info.irregular and info.gaps == 1
        al = store.align(["a"], rate_hz=100.0)
        x = al.materialize()[:, 0]
        grid = al.times_ns()
        inside = (grid > t[a - 1]) & (grid < t[a])
        assert np.isnan(x[inside]).all()
        assert not np.isnan(x[~inside]).any()
        assert inside.sum() >= lost - 2


def test_gamma_intervals_are_irregular_too():
    """Steps of a gamma distribution of shape 4 (coefficient of variation 0.5): 2 % of
    them exceed 2.5 median steps, too many for outages."""
    rng = np.random.default_rng(4)
    t = _times(rng.gamma(4.0, 0.0025, 20_000))  # mean 10 ms
    with _store(t, _wave(t, 2.0)) as store:
        info = store.info("a")
        assert info.irregular and info.gaps == 0
        assert info.rate_hz == pytest.approx(100.0, rel=0.02)
        assert not np.isnan(store.align(["a"], rate_hz=100.0).materialize()).any()


def test_a_dense_irregular_channel_is_low_passed_onto_a_slower_clock():
    """Exponential steps of 1 ms on average, decimated to 50 Hz: the FIR runs over the
    samples in their order (every step short of a gap is one slot), and the ticks have
    their values (but where a chance silence is a gap: :data:`CHANCE`), close to the
    2 Hz wave sampled."""
    rng = np.random.default_rng(5)
    t = _times(rng.exponential(0.001, 60_000))
    v = _wave(t, 2.0) + rng.normal(0, 0.05, t.size)
    with _store(t, v) as store:
        info = store.info("a")
        assert info.irregular and info.gaps <= CHANCE * t.size
        al = store.align(["a"], rate_hz=50.0)
        x = al.materialize()[:, 0]
        assert np.count_nonzero(np.isnan(x)) <= info.gaps
        truth = _wave(al.times_ns(), 2.0)
        assert np.nanquantile(np.abs(x - truth)[10:-10], 0.99) < 0.05


def test_a_long_spilled_irregular_channel_is_recognised(tmp_path):
    """Past 2**20 steps the median is taken of steps of several samples, whose spread
    is not the steps'; the irregularity test reads contiguous stretches (from the
    spilled, memory-mapped file here)."""
    rng = np.random.default_rng(6)
    t = _times(rng.exponential(0.001, 1_200_000))
    with _store(t, np.zeros(t.size), workdir=tmp_path, spill_samples=1 << 18) as store:
        assert any(tmp_path.iterdir())
        info = store.info("a")
        assert info.irregular and info.gaps <= CHANCE * t.size
        assert info.rate_hz == pytest.approx(1000.0, rel=0.01)


def test_uniform_intervals_keep_every_tick():
    """Steps uniform over 0.5-1.5 and 0.1-1.9 of the mean never reach 2.5 median steps:
    no gap, and the rate is the mean rate (by either rule)."""
    rng = np.random.default_rng(7)
    for lo, hi in ((0.005, 0.015), (0.001, 0.019)):
        t = _times(rng.uniform(lo, hi, 20_000))
        with _store(t, _wave(t, 1.0)) as store:
            info = store.info("a")
            assert info.gaps == 0
            assert info.rate_hz == pytest.approx(100.0, rel=0.01)
            assert not np.isnan(store.align(["a"], rate_hz=100.0).materialize()).any()


def _regular_gaps(t: np.ndarray, grid: np.ndarray, period: float) -> np.ndarray:
    """The ticks the regular rule leaves NaN: bracketed by a step over 2.5 periods."""
    right = np.clip(np.searchsorted(t, grid, "left"), 1, t.size - 1)
    on = np.isin(grid, t)
    return ~on & (t[right] - t[right - 1] > GAP_FACTOR * period)


@pytest.mark.parametrize("jitter", [0, 1_000_000])
def test_a_regular_channel_keeps_its_outages_and_bridges_lone_losses(jitter):
    """A 100 Hz clock (exact or with +-1 ms of jitter) that drops one sample in 50 and
    has outages of 3, 5 and 300 samples: its rate stays 100 Hz, the lone losses are
    bridged and the outages are gaps, tick for tick as the regular rule says."""
    rng = np.random.default_rng(8)
    n = 30_000
    t = np.arange(n, dtype=np.int64) * 10_000_000
    if jitter:
        t = t + rng.integers(-jitter, jitter, n)
    lost = np.r_[
        np.arange(25, n, 50), 1000 + np.arange(3), 9000 + np.arange(5), 20_000 + np.arange(300)
    ]
    t = np.delete(t, lost)
    with _store(t, _wave(t, 1.0)) as store:
        info = store.info("a")
        assert not info.irregular and info.bridge == GAP_FACTOR
        assert info.gaps == 3
        assert info.rate_hz == pytest.approx(100.0, rel=1e-4)
        al = store.align(["a"], rate_hz=100.0)
        x = al.materialize()[:, 0]
        want = _regular_gaps(t, al.times_ns(), 1e7)
        np.testing.assert_array_equal(np.isnan(x), want)
        assert 300 <= want.sum() <= 312


def test_a_regular_clock_losing_many_samples_stays_regular():
    """20 % of a 100 Hz clock's samples lost at random: 4 % of its steps are 3 periods
    or more (gaps, as before), but every step is a whole number of periods, which no
    irregular sampling gives: its rate stays 100 Hz and its gaps are the regular
    rule's."""
    rng = np.random.default_rng(9)
    t = (np.arange(30_000, dtype=np.int64) * 10_000_000)[rng.random(30_000) > 0.2]
    with _store(t, _wave(t, 1.0)) as store:
        info = store.info("a")
        assert not info.irregular
        assert info.rate_hz == 100.0
        assert info.gaps == int(np.count_nonzero(np.diff(t) > GAP_FACTOR * 1e7)) > 0
        al = store.align(["a"], rate_hz=100.0)
        want = _regular_gaps(t, al.times_ns(), 1e7)
        np.testing.assert_array_equal(np.isnan(al.materialize()[:, 0]), want)

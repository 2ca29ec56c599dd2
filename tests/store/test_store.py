"""The channel store: raw samples out of core, aligned blocks on a common clock."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.errors import StoreError
from analyzer.readers.base import ChannelChunk
from analyzer.store import ChannelStore, dominant_rate

NS = 1_000_000_000


def _chunks(name, t_ns, v, size):
    for s in range(0, t_ns.shape[0], size):
        yield ChannelChunk(name, t_ns[s : s + size], v[s : s + size])


def test_spilled_store_equals_in_memory_store(tmp_path):
    t = np.arange(50_000, dtype=np.int64) * 5_000_000
    v = np.sin(t / NS)
    mem = ChannelStore.from_chunks(_chunks("a", t, v, 1000))
    disk = ChannelStore.from_chunks(_chunks("a", t, v, 1000), tmp_path, spill_samples=4096)
    assert any(tmp_path.iterdir())  # really spilled
    for store in (mem, disk):
        tt, vv = store.raw("a")
        np.testing.assert_array_equal(tt, t)
        np.testing.assert_array_equal(vv, v)
    np.testing.assert_array_equal(
        mem.align(["a"]).materialize(), disk.align(["a"]).materialize(block=777)
    )
    mem.close()
    disk.close()


def test_jitter_is_interpolated_and_gaps_are_kept():
    rng = np.random.default_rng(0)
    t = np.arange(4000, dtype=np.int64) * 5_000_000 + rng.integers(-200_000, 200_000, 4000)
    keep = np.ones(4000, bool)
    keep[1000] = False  # one dropped sample: bridged
    keep[2000:2005] = False  # five: a gap
    t, v = t[keep], np.sin(2 * np.pi * t[keep] / NS)
    with ChannelStore.from_chunks([ChannelChunk("a", t, v)]) as store:
        info = store.info("a")
        assert info.gaps == 1 and info.samples == 3994
        al = store.align(["a"], rate_hz=200.0)
        x = al.materialize()[:, 0]
        grid = al.times_ns() / NS
        truth = np.sin(2 * np.pi * grid)
        nan = np.isnan(x)
        # the ticks inside the gap (plus, with jitter, the one at its edge) are NaN
        assert 5 <= nan.sum() <= 6 and nan[2000:2005].all() and not nan[:1999].any()
        assert np.nanmax(np.abs(x - truth)) < 0.01


def test_the_rate_of_jittered_stamps_is_their_mean_step():
    """Uniform jitter of +-2 ms at 100 Hz: 1 / the median step gave 99.86 Hz (the
    median of 6000 noisy steps is off by its sampling noise) and a common clock 0.14 %
    slow; the mean of the steps near the median is the rate to 1e-4. Regular steps, a
    gap and a doubled stamp aside, keep their exact rate."""
    rng = np.random.default_rng(7)
    n = 6000
    t = np.arange(n, dtype=np.int64) * 10_000_000 + rng.integers(-2_000_000, 2_000_000, n)
    t.sort()
    with ChannelStore.from_chunks([ChannelChunk("a", t, np.zeros(n))]) as store:
        assert store.info("a").rate_hz == pytest.approx(100.0, rel=1e-4)
    regular = np.arange(n, dtype=np.int64) * 5_000_000
    regular = np.delete(regular, np.arange(100, 110))  # a gap
    with ChannelStore.from_chunks([ChannelChunk("b", regular, np.zeros(regular.size))]) as store:
        assert store.info("b").rate_hz == 200.0


def test_channel_on_the_clock_keeps_its_samples_and_gaps():
    """A channel sampled on the common clock takes its samples as they are (no
    interpolation); blocks with missing samples keep their gap; a second channel off the
    clock by a quarter period is interpolated as before."""
    t = np.arange(5000, dtype=np.int64) * 10_000_000  # 100 Hz
    v = np.cos(t / NS)
    v[100] = np.nan  # a NaN reading stays NaN
    keep = np.ones(5000, bool)
    keep[3000:3010] = False  # a gap
    off = t + 2_500_000
    chunks = [ChannelChunk("a", t[keep], v[keep]), ChannelChunk("b", off, np.sin(off / NS))]
    with ChannelStore.from_chunks(chunks) as store:
        al = store.align(["a", "b"], rate_hz=100.0, start_ns=0, end_ns=int(t[-1]))
        x = al.materialize(block=777)
    expect = np.where(keep, v, np.nan)
    np.testing.assert_array_equal(x[:, 0], expect)
    grid = al.times_ns() / NS
    inside = grid >= off[0] / NS
    assert np.isnan(x[~inside, 1]).sum() == 0  # held at the edge within half a period
    assert np.max(np.abs(x[inside, 1] - np.sin(grid[inside]))) < 1e-4


def test_faster_channel_is_low_passed_before_decimation():
    t = np.arange(80_000, dtype=np.int64) * 1_250_000  # 800 Hz
    sec = t / NS
    v = np.sin(2 * np.pi * 2.0 * sec) + 0.5 * np.sin(2 * np.pi * 170.0 * sec)
    with ChannelStore.from_chunks([ChannelChunk("fast", t, v)]) as store:
        x = store.align(["fast"], rate_hz=200.0).materialize()[:, 0]
    grid = np.arange(x.shape[0]) / 200.0
    # the 170 Hz tone (above the 100 Hz Nyquist) would alias to 30 Hz; it must be gone
    err = x[200:-200] - np.sin(2 * np.pi * 2.0 * grid[200:-200])
    assert np.max(np.abs(err)) < 1e-3


def _decimated(t, v, rate_hz):
    with ChannelStore.from_chunks([ChannelChunk("fast", t, v)]) as store:
        return store.align(["fast"], rate_hz=rate_hz).materialize()[:, 0]


def test_decimation_keeps_a_level_at_the_ends_and_beside_nans():
    """The anti-aliasing filter leaves out samples it has not, rather than reading them
    as zeros: gravity at 100 Hz on a 20 Hz clock began at 5.79 and swung to 10.54 at
    the record's ends and beside a NaN (probe of the thirtieth session)."""
    rng = np.random.default_rng(0)
    t = np.arange(4000, dtype=np.int64) * 10_000_000  # 100 Hz, 40 s
    v = 9.81 + 0.001 * rng.standard_normal(t.shape[0])
    v[1000] = np.nan
    x = _decimated(t, v, 20.0)
    assert np.isnan(x[200])  # the NaN's tick stays a gap
    near = np.r_[x[:10], x[190:200], x[201:211], x[-10:]]
    assert np.all(np.isfinite(near))
    assert np.max(np.abs(near - 9.81)) < 0.005


def test_decimation_does_not_mix_the_two_sides_of_a_gap():
    """Samples before and after an outage are filtered apart: a level of 0 before a
    10-second gap and of 10 after it stay 0 and 10 up to the gap's edges."""
    t = np.r_[np.arange(2000), np.arange(3000, 5000)].astype(np.int64) * 10_000_000
    v = np.r_[np.zeros(2000), np.full(2000, 10.0)]
    x = _decimated(t, v, 20.0)
    grid = np.arange(x.shape[0]) / 20.0
    before = grid < 19.9
    after = grid > 30.05
    np.testing.assert_allclose(x[before], 0.0, atol=1e-9)
    np.testing.assert_allclose(x[after], 10.0, atol=1e-9)
    assert np.all(np.isnan(x[(grid > 20.05) & (grid < 29.95)]))


def test_decimation_filters_through_a_few_lost_samples():
    """A 1 kHz channel that loses 3 samples of every 53, decimated to 10 Hz: the taps on
    the lost samples are left out, the rest carry the value (each stretch between losses
    is shorter than the filter, and a filter run per stretch gave NaN everywhere)."""
    n = 60_000
    t = np.arange(n, dtype=np.int64) * 1_000_000
    keep = np.ones(n, dtype=bool)
    for k in range(3):
        keep[np.arange(0, n - 3, 53) + k] = False
    x = _decimated(t[keep], 1.0 + np.sin(2 * np.pi * 0.2 * t[keep] / NS), 10.0)
    grid = 0.003 + np.arange(x.shape[0]) / 10.0  # the clock starts at the first sample
    ok = np.isfinite(x)
    assert ok.mean() > 0.9  # NaN only where a tick falls in a loss (3 of 53 ms)
    truth = 1.0 + np.sin(2 * np.pi * 0.2 * grid)
    # at the ends a one-sided filter lags the sine a little
    np.testing.assert_allclose(x[ok][1:-1], truth[ok][1:-1], atol=0.02)
    np.testing.assert_allclose(x[ok], truth[ok], atol=0.05)


def test_decimation_keeps_a_channel_present_in_bursts():
    """A 1 kHz channel present 20 ms of every 50 (a transport that batches), decimated
    to 10 Hz: the filter's taps have their samples less than half the time, but those
    carry the value (all 600 ticks were NaN while less than half the filter's weight
    present meant no value)."""
    t = np.arange(60_000, dtype=np.int64) * 1_000_000
    keep = (np.arange(60_000) % 50) < 20
    x = _decimated(t[keep], 2.0 + np.sin(2 * np.pi * 0.2 * t[keep] / NS), 10.0)
    grid = np.arange(x.shape[0]) / 10.0
    ok = np.isfinite(x)
    assert ok.mean() > 0.95
    np.testing.assert_allclose(x[ok], 2.0 + np.sin(2 * np.pi * 0.2 * grid[ok]), atol=0.05)


def test_decimation_away_from_edges_is_the_plain_convolution():
    """Where every tap has its sample the result is the plain FIR's, to the last bit."""
    from scipy import signal

    from analyzer.store.store import _low_passed

    rng = np.random.default_rng(1)
    t = np.arange(5000, dtype=np.int64) * 10_000_000
    v = rng.standard_normal(5000)
    taps = signal.firwin(41, 9.0, fs=100.0)
    plain = signal.oaconvolve(v, taps, mode="same")
    ours = _low_passed(t, v, taps, 1e7)
    np.testing.assert_array_equal(ours[25:-25], plain[25:-25])


def test_out_of_order_chunks_are_sorted():
    t = np.arange(1000, dtype=np.int64) * 10_000_000
    v = t.astype(float)
    chunks = [ChannelChunk("a", t[500:], v[500:]), ChannelChunk("a", t[:500], v[:500])]
    with ChannelStore.from_chunks(chunks) as store:
        tt, vv = store.raw("a")
        assert np.all(np.diff(tt) > 0) and np.array_equal(vv, v)


def test_select_and_constant_channels():
    t = np.arange(100, dtype=np.int64) * 10_000_000
    chunks = [
        ChannelChunk("/imu.x", t, np.sin(t / 1e8)),
        ChannelChunk("/imu.flag", t, np.ones(100)),
    ]
    with ChannelStore.from_chunks(chunks) as store:
        assert store.select(None) == ["/imu.x"]
        assert store.select(["/imu.*"]) == ["/imu.x", "/imu.flag"]
        with pytest.raises(StoreError, match="unknown channel"):
            store.raw("nope")


def test_select_leaves_out_bang_patterns():
    """``!GLOB`` leaves channels out: from what the other patterns select, or from the
    default selection when every pattern is an exclusion; a channel named ``!x`` is
    still selected by its exact name; an exclusion that matches nothing is unmatched."""
    t = np.arange(100, dtype=np.int64) * 10_000_000
    wave = np.sin(t / 1e8)
    chunks = [
        ChannelChunk("/imu.x", t, wave),
        ChannelChunk("/imu.y", t, 2 * wave),
        ChannelChunk("/scan.ranges[0]", t, 3 * wave),
        ChannelChunk("/imu.flag", t, np.ones(100)),
        ChannelChunk("!odd", t, 4 * wave),
    ]
    with ChannelStore.from_chunks(chunks) as store:
        assert store.select(["!/scan.*"]) == ["/imu.x", "/imu.y", "!odd"]
        assert store.select(["!/scan.*"], numeric_only=False) == [
            "/imu.x",
            "/imu.y",
            "/imu.flag",
            "!odd",
        ]
        assert store.select(["/imu.*", "!/imu.y"]) == ["/imu.x", "/imu.flag"]
        assert store.select(["!odd"]) == ["!odd"]  # the exact name wins
        assert store.unmatched(["/imu.*", "!/nothing*", "zz"]) == ["zz", "!/nothing*"]
        assert store.unmatched(["!/imu.y", "!odd"]) == []


def test_dominant_rate():
    assert dominant_rate([200.01, 199.99, 100.0]) == 200.0
    assert dominant_rate([100.0, 100.0, 200.0]) == 100.0
    with pytest.raises(StoreError, match="clock rate"):
        dominant_rate([])


def test_summary_of_a_spilled_channel_reads_its_times_a_block_at_a_time(tmp_path, monkeypatch):
    """The period of a long spilled channel comes from spread steps ``t[::stride]``, taken
    a block at a time with each block's pages given back (taken at once, they touched
    every page of the channel's time file: all of it resident, as long as the archive):
    the same summary as from the times in memory."""
    from analyzer import paging
    from analyzer.store import store as st

    n = 2_500_000  # stride 2: every page of the times is touched
    rng = np.random.default_rng(4)
    t = np.cumsum(rng.integers(9_000_000, 11_000_000, n)).astype(np.int64)
    t[1_000_000:] += 5_000_000_000  # a gap
    v = rng.standard_normal(n)
    tp, vp = tmp_path / "c.t", tmp_path / "c.v"
    t.tofile(tp)
    v.tofile(vp)
    tm = np.memmap(tp, dtype=np.int64, mode="r")
    vm = np.memmap(vp, dtype=np.float64, mode="r")
    released: list[int] = []
    real = paging.release
    monkeypatch.setattr(st, "release", lambda a: (released.append(a.shape[0]), real(a)))
    got = st._summarize("c", tm, vm, block=1 << 19)
    assert got == st._summarize("c", t, v, block=1 << 19)
    assert got.gaps == 1
    assert max(released) <= (1 << 19) + 1  # never the whole channel at once


def test_records_far_apart_that_share_no_channel_are_named_as_such():
    # two files of an archive, years apart, with no channel in common (the realdata
    # audit: two ROS 1 bags of 2017 and 2024 got "a timestamp far from the others")
    day = 86_400 * 10**9
    t = np.arange(0, 10**10, 10**7, dtype=np.int64)
    chunks = [
        ChannelChunk("a", t, np.sin(t / 1e9)),
        ChannelChunk("b", t, np.cos(t / 1e9)),
        ChannelChunk("c", t + 2000 * day, np.sin(t / 1e9)),
        ChannelChunk("d", t + 2000 * day, np.cos(t / 1e9)),
    ]
    store = ChannelStore.from_chunks(chunks)
    with pytest.raises(StoreError, match="no channel has a sample for 2000 days between a's"):
        store.align(["a", "b", "c", "d"])
    store.close()


def test_a_lone_far_sample_of_any_channel_is_named():
    t = np.arange(0, 10**10, 10**7, dtype=np.int64)
    far = np.append(t[:500], 5 * 10**17)  # b: fewer samples than a, one far
    chunks = [ChannelChunk("a", t, np.sin(t / 1e9)), ChannelChunk("b", far, np.cos(far / 1e9))]
    store = ChannelStore.from_chunks(chunks)
    with pytest.raises(StoreError, match="the last sample of b lies"):
        store.align(["a", "b"])
    store.close()

"""The aligned matrix written straight from the raw samples (:meth:`AlignedSeries.materialize`,
its on-the-clock shortcut and its threads) equals the reference form: the blocks of
:meth:`AlignedSeries.block` (every channel through ``_resample``) stacked."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.readers.base import ChannelChunk
from analyzer.store import ChannelStore
from analyzer.store import store as store_module

NS = 1_000_000_000
PERIOD = 10_000_000  # 100 Hz


def _store(tmp_path=None, spill=1 << 22):
    rng = np.random.default_rng(3)
    n = 30_000
    t = np.arange(n, dtype=np.int64) * PERIOD
    chunks = []
    # on the clock throughout
    chunks.append(ChannelChunk("clock", t, rng.normal(size=n)))
    # on the clock with a gap and a NaN
    keep = np.ones(n, bool)
    keep[5000:5300] = False
    v = rng.normal(size=n)
    v[100] = np.nan
    chunks.append(ChannelChunk("gapped", t[keep], v[keep]))
    # on the clock for the first half, then shifted by a third of a period
    shifted = t.copy()
    shifted[n // 2 :] += PERIOD // 3
    chunks.append(ChannelChunk("half", shifted, rng.normal(size=n)))
    # jittered around the clock
    jitter = t + rng.integers(-PERIOD // 10, PERIOD // 10, n)
    jitter.sort()
    chunks.append(ChannelChunk("jitter", jitter, rng.normal(size=n)))
    # starts late, ends early (NaN at the edges of the clock)
    chunks.append(ChannelChunk("late", t[700:-900], rng.normal(size=n - 1600)))
    # four times faster: decimated
    fast_t = np.arange(4 * n, dtype=np.int64) * (PERIOD // 4)
    chunks.append(ChannelChunk("fast", fast_t, rng.normal(size=4 * n)))
    # a duplicated timestamp in the middle of an otherwise on-clock channel
    dup_t = np.insert(t, 12_345, t[12_345])
    chunks.append(ChannelChunk("dup", dup_t, rng.normal(size=n + 1)))
    return ChannelStore.from_chunks(iter(chunks), tmp_path, spill_samples=spill)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("block", [777, 4096, 1 << 16])
def test_materialize_equals_the_stacked_blocks(tmp_path, monkeypatch, threads, block):
    monkeypatch.setattr(store_module, "ALIGN_THREADS", threads)
    with _store(tmp_path / "s", spill=20_000) as store:
        names = store.names
        assert len(names) == 7
        aligned = store.align(names, rate_hz=100.0)
        reference = np.vstack([blk for _, blk in aligned.blocks(block)])
        got = aligned.materialize(block=block)
        np.testing.assert_array_equal(got, reference)
        written: list[int] = []
        pwrite = store_module.os.pwrite

        def counting(fd, data, offset):
            done = pwrite(fd, data, offset)
            written.append(done)
            return done

        monkeypatch.setattr(store_module.os, "pwrite", counting)
        on_disk = aligned.materialize(tmp_path / "aligned.npy", block=block)
        np.testing.assert_array_equal(np.asarray(on_disk), reference)
        # every byte went to the file by pwrite, none through the new file's mapping
        assert sum(written) == reference.nbytes
        assert len(written) >= -(-reference.shape[0] // block)
        # the shortcut did apply (and did not apply) where expected
        clock = store.raw("clock")[0]
        grid = aligned.times_ns(0, 1000)
        assert store_module._on_clock(clock, grid, 100.0, 100.0) == 0
        half = store.raw("half")[0]
        late_grid = aligned.times_ns(20_000, 21_000)
        assert store_module._on_clock(half, late_grid, 100.0, 100.0) is None
        fast = store.raw("fast")[0]
        assert store_module._on_clock(fast, grid, 400.0, 100.0) is None


def test_finalize_on_threads_keeps_channel_order_and_summaries(tmp_path, monkeypatch):
    with _store() as threaded:
        infos = threaded.infos()
    monkeypatch.setattr(store_module, "FINALIZE_THREADS", 1)
    with _store() as serial:
        assert [i.name for i in infos] == serial.names
        assert infos == serial.infos()
        names = ["clock", "gapped", "half", "jitter", "late", "fast", "dup"]
        assert [i.name for i in infos] == names


@pytest.mark.parametrize("n", [0, 1, 4095, 4096, 4097, 3 * 4096, 50_000])
def test_finder_equals_searchsorted(n):
    """The alignment's search through a long time array (a coarse index, then one
    stretch) gives numpy's searchsorted on both sides, with repeated times, times
    before, between and after the samples, and on the stretches' edges."""
    rng = np.random.default_rng(n)
    t = np.sort(rng.integers(0, 10 * n + 10, n)).astype(np.int64)
    t[n // 2 : n // 2 + min(n // 2, 5000)] = t[n // 2] if n else 0  # a long run of one time
    find = store_module._Finder(t)
    keys = np.concatenate(
        [t[:: max(1, n // 500)], t[:: max(1, n // 500)] + 1, [-5, 0, 10 * n + 20]]
    ).astype(np.int64)
    keys = np.concatenate([keys, t[4095::4096], t[4096::4096]]) if n else keys
    for x in keys:
        for side in ("left", "right"):
            assert find(x, side) == int(np.searchsorted(t, x, side)), (x, side)

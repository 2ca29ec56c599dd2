"""Channels whose chunks come with one time array (the fields of one message) keep it
once (:meth:`ChannelStore._sharing`): the same samples as a store given a copy per
channel, however the chunks, spills, sort orders and divergences fall."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.readers.base import ChannelChunk
from analyzer.store import ChannelStore


def _stores(chunks, tmp_path, spill):
    shared = ChannelStore.from_chunks(chunks, tmp_path / "shared", spill_samples=spill)
    copies = [ChannelChunk(c.name, c.t_ns.copy(), c.values) for c in chunks]
    plain = ChannelStore.from_chunks(copies, tmp_path / "plain", spill_samples=spill)
    return shared, plain


def _same(shared, plain):
    assert shared.names == plain.names
    for name in plain.names:
        ts, vs = shared.raw(name)
        tp, vp = plain.raw(name)
        np.testing.assert_array_equal(np.asarray(ts), np.asarray(tp), err_msg=name)
        np.testing.assert_array_equal(np.asarray(vs), np.asarray(vp), err_msg=name)
        assert shared.info(name) == plain.info(name)


def _topic(rng, start, n, unsorted=False):
    t = start + np.arange(n, dtype=np.int64) * 10_000_000
    if unsorted:
        rng.shuffle(t[: n // 2])
    return t


@pytest.mark.parametrize("spill", [7, 50, 1 << 22])
def test_fields_of_one_message_keep_one_time_array(tmp_path, spill):
    rng = np.random.default_rng(0)
    chunks, start = [], 0
    for _ in range(6):
        t = _topic(rng, start, 20)
        start = int(t[-1]) + 10_000_000
        chunks += [ChannelChunk(f"a{k}", t, rng.standard_normal(20)) for k in range(4)]
    shared, plain = _stores(chunks, tmp_path, spill)
    _same(shared, plain)
    lead = shared.raw("a0")[0]
    for k in (1, 2, 3):
        assert np.shares_memory(shared.raw(f"a{k}")[0], lead)
    if spill < 120:  # spilled: one times file for the four fields
        assert sorted(p.name for p in (tmp_path / "shared").glob("*.t")) == ["ch00000.t"]
        assert len(list((tmp_path / "plain").glob("*.t"))) == 4


@pytest.mark.parametrize("own_share", [0.15, 0.3])
@pytest.mark.parametrize("spill", [7, 33, 1 << 22])
@pytest.mark.parametrize("seed", range(12))
def test_any_mix_of_shared_diverging_and_missed_chunks(tmp_path, spill, seed, own_share):
    """Topics whose fields skip a chunk, get their own times from some chunk on, start
    late, or come unsorted: every channel's samples are those of a store with copies."""
    rng = np.random.default_rng(seed)
    chunks, start = [], 0
    for _ in range(int(rng.integers(3, 9))):
        n = int(rng.integers(1, 15))
        t = _topic(rng, start, n, unsorted=bool(rng.random() < 0.2))
        start = int(t.max()) + 10_000_000
        for k in range(5):
            r = rng.random()
            if r < 0.15:
                continue  # this field missed the chunk
            if r < own_share:  # its own times (equal or not)
                own = t.copy() if rng.random() < 0.5 else t + int(rng.integers(1, 5))
                chunks.append(ChannelChunk(f"f{k}", own, rng.standard_normal(n)))
            else:
                chunks.append(ChannelChunk(f"f{k}", t, rng.standard_normal(n)))
    shared, plain = _stores(chunks, tmp_path, spill)
    _same(shared, plain)


def test_a_field_that_missed_a_chunk_does_not_take_the_next_one_as_shared(tmp_path):
    t1, t2 = np.arange(3, dtype=np.int64), np.arange(3, 6, dtype=np.int64)
    chunks = [
        ChannelChunk("x", t1, np.zeros(3)),
        ChannelChunk("x", t2, np.ones(3)),
        ChannelChunk("y", t2, np.full(3, 2.0)),  # y's first chunk is x's second
    ]
    shared, plain = _stores(chunks, tmp_path, 1 << 22)
    _same(shared, plain)
    np.testing.assert_array_equal(shared.raw("y")[0], t2)


@pytest.mark.parametrize("spill", [3, 1 << 22])
def test_a_field_that_missed_the_last_chunks_keeps_its_own_times(tmp_path, spill):
    t1, t2 = np.arange(3, dtype=np.int64), np.arange(3, 6, dtype=np.int64)
    chunks = [
        ChannelChunk("x", t1, np.zeros(3)),
        ChannelChunk("y", t1, np.ones(3)),
        ChannelChunk("x", t2, np.ones(3)),  # y has no second chunk
    ]
    shared, plain = _stores(chunks, tmp_path, spill)
    _same(shared, plain)
    np.testing.assert_array_equal(shared.raw("y")[0], t1)


def test_a_field_that_diverges_after_its_leader_spilled_alone(tmp_path):
    """The leader's chunk filled the buffers and was spilled before the field that
    shares it came: the field's buffered times are in the leader's file."""
    t1, t2 = np.arange(2, dtype=np.int64), np.arange(2, 4, dtype=np.int64)
    chunks = [
        ChannelChunk("other", np.arange(10, 13, dtype=np.int64), np.zeros(3)),
        ChannelChunk("x", t1, np.zeros(2)),  # 5 buffered: spilled with x's chunk
        ChannelChunk("y", t1, np.ones(2)),  # shares it, buffered
        ChannelChunk("x", t2, np.zeros(2)),
        ChannelChunk("y", t2 + 1, np.ones(2)),  # its own times from here
    ]
    shared, plain = _stores(chunks, tmp_path, 5)
    _same(shared, plain)
    np.testing.assert_array_equal(shared.raw("y")[0], [0, 1, 3, 4])


def _mixed_chunks(seed):
    """Two topics of several fields (the last field of each with its own times from
    some chunk on, some chunks unsorted) and a channel of its own: groups of shared
    times and not."""
    rng = np.random.default_rng(seed)
    chunks, start = [], 0
    for _ in range(5):
        n = int(rng.integers(20, 40))
        for topic, fields in (("a", 4), ("b", 3)):
            t = _topic(rng, start, n, unsorted=bool(rng.random() < 0.3))
            for k in range(fields):
                own = k == fields - 1 and rng.random() < 0.4
                times = t + int(rng.integers(0, 3)) if own else t
                chunks.append(ChannelChunk(f"{topic}{k}", times, rng.standard_normal(n)))
        alone = start + np.sort(rng.integers(0, 10_000_000 * n, n))
        chunks.append(ChannelChunk("alone", alone, rng.standard_normal(n)))
        start += 10_000_000 * n
    return chunks


@pytest.mark.parametrize("block", [16, 1 << 22])
@pytest.mark.parametrize("spill", [50, 1 << 22])
@pytest.mark.parametrize("seed", range(4))
def test_shared_times_tally_as_a_copy_per_channel(tmp_path, spill, seed, block):
    """The store's tally sums a shared time array once per block for all the channels
    that share it: the same sums, bit for bit, as a store with a copy of the times per
    channel (summed per channel), in the same order of channels."""
    from analyzer.readers.tally import Tally

    chunks = _mixed_chunks(seed)
    shared, plain = _stores(chunks, tmp_path, spill)
    assert shared.raw("a1")[0] is shared.raw("a0")[0] is shared.raw("a2")[0]
    assert shared.raw("b1")[0] is shared.raw("b0")[0]
    fed = Tally()
    for c in chunks:
        fed.add(c.name, c.t_ns.copy(), c.values)
    got, want = shared.tally(block), plain.tally(block)
    assert list(got.sums.items()) == list(want.sums.items())
    assert fed.differences(got, "fed", "stored") == []


def test_a_shared_time_array_is_summed_once_per_block(tmp_path, monkeypatch):
    """Four fields with one time array, read in 4 blocks: 4 sums of times, not 16."""
    from analyzer.readers import tally

    t = np.arange(60, dtype=np.int64) * 10_000_000
    chunks = [ChannelChunk(f"f{k}", t, np.full(60, float(k))) for k in range(4)]
    store = ChannelStore.from_chunks(chunks, tmp_path / "store")
    summed = []
    monkeypatch.setattr(tally, "bitsum", lambda a: summed.append(a.dtype) or 0)
    store.tally(16)
    assert summed.count(np.dtype(np.int64)) == 4
    assert summed.count(np.dtype(np.float64)) == 16

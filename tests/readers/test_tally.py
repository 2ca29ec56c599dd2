"""The samples' checksums (analyzer.readers.tally) and the reorderer's own check: a tally
does not depend on the order or chunking of the samples, and notices one bit changed, a
sample lost, a NaN's payload; the reorderer raises IntegrityError where what it held
changed before its release (a CSV's values are views of Arrow's buffers until then)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.errors import IntegrityError
from analyzer.readers._common import Reorderer
from analyzer.readers.base import ChannelChunk
from analyzer.readers.tally import Tally, bitsum


def _samples(n: int = 1000, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return np.arange(n, dtype=np.int64) * 10_000_000, rng.standard_normal(n)


def test_bitsum_wraps_modulo_2_64():
    a = np.array([-1, -1], dtype=np.int64)  # 0xFFFF... twice
    assert bitsum(a) == (2 * (2**64 - 1)) % 2**64
    assert bitsum(np.zeros(0, dtype=np.float64)) == 0


def test_a_tally_does_not_depend_on_order_or_chunking():
    t, v = _samples()
    whole, pieces = Tally(), Tally()
    whole.add("a", t, v)
    order = np.random.default_rng(1).permutation(t.size)
    for part in np.array_split(order, 7):
        pieces.add("a", t[part], v[part])
    assert whole.differences(pieces, "x", "y") == []


@pytest.mark.parametrize(
    ("change", "said"),
    [
        (lambda t, v: (t[1:], v[1:]), "1000 samples x, 999 y"),
        (lambda t, v: (t, np.where(np.arange(v.size) == 5, np.nextafter(v, 9), v)), "values"),
        (lambda t, v: (np.where(np.arange(t.size) == 0, t + 1, t), v), "times"),
        (lambda t, v: (t, np.r_[v[:-1], -0.0]), "values"),
    ],
)
def test_a_tally_notices_a_sample_lost_or_one_bit_changed(change, said):
    t, v = _samples()
    v[-1] = 0.0
    before, after = Tally(), Tally()
    before.add("a", t, v)
    after.add("a", *change(t, v))
    found = before.differences(after, "x", "y")
    assert len(found) == 1 and found[0].startswith("'a': ") and said in found[0], found


def test_nan_payloads_count():
    t = np.arange(2, dtype=np.int64)
    quiet = np.array([np.nan, 1.0])
    other = quiet.copy()
    other.view(np.uint64)[0] ^= 1  # another NaN
    a, b = Tally(), Tally()
    a.add("a", t, quiet)
    b.add("a", t, other)
    assert a.differences(b, "x", "y") != []


def test_a_shared_time_array_is_summed_once_and_counted_per_channel():
    t, v = _samples()
    shared, apart = Tally(), Tally()
    for name in ("a", "b"):
        shared.add(name, t, v)
        apart.add(name, t.copy(), v)
    assert shared.differences(apart, "x", "y") == []
    assert shared.sums["b"][0] == 1000


def _drained(r: Reorderer) -> list[ChannelChunk]:
    return list(r.flush())


def test_the_reorderer_passes_its_own_check_with_drops_and_disorder():
    r = Reorderer(window_ns=50_000_000, batch_samples=100)
    t, v = _samples(1000)
    out = []
    for a in range(0, 1000, 200):
        part = slice(a, a + 200)
        tt = t[part][::-1].copy()  # reversed within a batch: sorted by the reorderer
        r.push("a", tt, v[part][::-1].copy())
        r.push("b", tt, v[part][::-1].copy())
        out += list(r.release(None))
    r.push("a", t[:3].copy(), v[:3].copy())  # far back: dropped and counted
    out += _drained(r)
    assert r.dropped == {"a": 3}
    assert sum(len(c) for c in out if c.name == "a") == 1000


def test_the_reorderer_raises_where_a_held_array_changed():
    r = Reorderer()
    t, v = _samples()
    held = v.copy()
    r.push("a", t, held)
    held[:10] = 0.0  # (the memory of a view overwritten while held)
    with pytest.raises(
        IntegrityError, match=r"reordering: 'a': 1000 samples pushed .*values differ"
    ):
        _drained(r)


def test_the_reorderer_raises_where_rows_were_lost_while_held():
    r = Reorderer()
    t, v = _samples(3000)
    r.push("a", t, v)
    r._t["a"][0] = t[2359:]  # the first 2 359 rows gone, as once under load
    r._v["a"][0] = v[2359:]
    with pytest.raises(IntegrityError, match=r"'a': 3000 samples pushed, 641 released or dropped"):
        _drained(r)

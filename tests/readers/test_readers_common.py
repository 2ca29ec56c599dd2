"""Shared machinery: time ordering across batches, the archive's overlap guard, byte
gathering."""

from __future__ import annotations

import hashlib
from pathlib import Path

import numpy as np
from readers_helpers import collect

from analyzer.readers._common import (
    Reorderer,
    concat_payloads,
    file_digest,
    gather_rows,
    gather_uint,
    monotonic,
)
from analyzer.readers.base import ChannelChunk


def _arr(*values: int) -> np.ndarray:
    return np.asarray(values, dtype=np.int64)


def test_reorderer_with_bounds_sorts_across_batches() -> None:
    reorder = Reorderer(batch_samples=0)
    out: list[ChannelChunk] = []
    reorder.push("a", _arr(5, 1, 3), np.array([5.0, 1.0, 3.0]))
    out += reorder.release(4)  # nothing below 4 will come any more
    assert [c.t_ns.tolist() for c in out] == [[1, 3]]
    reorder.push("a", _arr(4, 6), np.array([4.0, 6.0]))
    out += reorder.flush()
    t, v = collect(out)["a"]
    assert t.tolist() == [1, 3, 4, 5, 6] and v.tolist() == [1.0, 3.0, 4.0, 5.0, 6.0]
    assert reorder.dropped == {}


def test_reorderer_window_and_late_samples() -> None:
    reorder = Reorderer(window_ns=10, batch_samples=0)
    out: list[ChannelChunk] = []
    reorder.push("a", _arr(0, 5, 30), np.zeros(3))
    out += reorder.release(None)  # releases t < 30 - 10
    assert [c.t_ns.tolist() for c in out] == [[0, 5]]
    reorder.push("a", _arr(25, 3), np.zeros(2))  # 25 fits in the window, 3 is too late
    out += reorder.flush()
    assert collect(out)["a"][0].tolist() == [0, 5, 25, 30]
    assert reorder.dropped == {"a": 1}
    assert "1 samples dropped" in reorder.drop_report()[0]


def test_reorderer_holds_small_batches() -> None:
    reorder = Reorderer(batch_samples=100)
    reorder.push("a", _arr(1, 2), np.zeros(2))
    assert list(reorder.release(10)) == []
    assert [len(c) for c in reorder.flush()] == [2]


def test_monotonic_guard() -> None:
    chunks = [
        ChannelChunk("a", _arr(1, 2, 3), np.zeros(3)),
        ChannelChunk("a", _arr(3, 4), np.ones(2)),
        ChannelChunk("b", _arr(0), np.zeros(1)),
    ]
    last: dict[str, int] = {}
    dropped: dict[str, int] = {}
    loose = list(monotonic(chunks, last, dropped))
    assert [c.t_ns.tolist() for c in loose] == [[1, 2, 3], [3, 4], [0]]
    strict = list(monotonic(chunks, {}, dropped, strict=True))
    assert [c.t_ns.tolist() for c in strict] == [[1, 2, 3], [4], [0]]
    assert dropped == {"a": 1}


def test_gathering() -> None:
    buf, starts, sizes = concat_payloads([b"\x01\x00\x00\x00ab", b"\x02\x00\x00\x00cd"])
    assert starts.tolist() == [0, 6] and sizes.tolist() == [6, 6]
    assert gather_uint(buf, starts, 4).tolist() == [1, 2]
    rows = gather_rows(buf, starts, 6)
    assert rows.flags.c_contiguous and rows[:, 4:].tobytes() == b"abcd"
    uneven = gather_rows(buf, np.asarray([0, 5], dtype=np.int64), 1)
    assert uneven[:, 0].tolist() == [1, ord("b")]


def test_file_digest_streams(tmp_path: Path) -> None:
    data = np.random.default_rng(0).bytes(3 * (1 << 20) + 17)
    path = tmp_path / "blob"
    path.write_bytes(data)
    assert file_digest([path]) == (len(data), hashlib.sha256(data).hexdigest())

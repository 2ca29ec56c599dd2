"""The decoder of cut compressed chunks (:mod:`analyzer.readers.cut_chunk`): what it
gives of an LZ4 frame cut anywhere is exactly the start of the data, more than the
frame's whole blocks wherever the cut is inside a block, and damage is an error, not
bytes made up. The readers' use of it: ``test_cut_compressed_chunks52.py``."""

from __future__ import annotations

import os

import lz4.frame
import numpy as np
import pytest

from analyzer.readers.cut_chunk import CutDataError, cut_prefix, lz4_frame_prefix


def _source(n: int = 300_000, seed: int = 3) -> bytes:
    """Bytes that compress as records do: runs, repeats near and far, and noise."""
    rng = np.random.default_rng(seed)
    words = [rng.integers(0, 256, size=int(k), dtype=np.uint8).tobytes() for k in range(3, 40)]
    parts = []
    size = 0
    while size < n:
        kind = int(rng.integers(0, 4))
        if kind == 0:
            part = bytes([int(rng.integers(0, 256))]) * int(rng.integers(1, 300))
        elif kind == 1:
            part = os.urandom(int(rng.integers(1, 30)))
        else:
            part = words[int(rng.integers(0, len(words)))]
        parts.append(part)
        size += len(part)
    return b"".join(parts)


@pytest.mark.parametrize("linked", [True, False])
@pytest.mark.parametrize("block_size", [lz4.frame.BLOCKSIZE_MAX64KB, lz4.frame.BLOCKSIZE_MAX4MB])
def test_lz4_frame_prefix_is_the_start_of_the_data_at_every_cut(
    linked: bool, block_size: int
) -> None:
    """At cuts all through a frame (linked blocks or not, with block and content
    checksums), what is decoded is exactly the start of the data, never less than the
    frame's whole blocks give, and more wherever the cut is well inside a block."""
    src = _source()
    frame = lz4.frame.compress(
        src, block_size=block_size, block_linked=linked, content_checksum=True, block_checksum=True
    )
    assert lz4_frame_prefix(frame) == src
    more = 0
    cuts = range(11, len(frame), len(frame) // 97)
    for cut in cuts:
        got = lz4_frame_prefix(frame[:cut])
        assert got == src[: len(got)], cut
        whole_blocks = lz4.frame.LZ4FrameDecompressor().decompress(frame[:cut])
        assert len(got) >= len(whole_blocks)
        more += len(got) > len(whole_blocks)
    assert more > 0.8 * len(cuts)


def test_lz4_block_cut_one_byte_short_loses_one_byte() -> None:
    """An LZ4 block ends with literals: cut one byte short, all but the last byte."""
    src = _source(50_000)
    frame = lz4.frame.compress(src, block_size=lz4.frame.BLOCKSIZE_MAX4MB)
    end_mark = 4  # (no content checksum)
    assert lz4_frame_prefix(frame[: -end_mark - 1]) == src[:-1]


def test_damaged_lz4_data_is_an_error_not_made_up_bytes() -> None:
    """A match reaching before the block's start is damage, said, not decoded."""
    src = _source(50_000)
    frame = bytearray(lz4.frame.compress(src, block_size=lz4.frame.BLOCKSIZE_MAX4MB))
    with pytest.raises(CutDataError, match="no LZ4 frame"):
        cut_prefix("lz4", b"\x00" * 20)
    first_token = 7 + (8 if frame[4] & 0x08 else 0) + 4  # (header, content size, block size)
    frame[first_token] = 0x0F  # no literal, then a match: it can only reach before
    with pytest.raises(CutDataError, match="reaches before the block's data"):
        cut_prefix("lz4", bytes(frame[:1000]))
    with pytest.raises(CutDataError, match="unsupported chunk compression 'xz'"):
        cut_prefix("xz", b"")

"""What can be had from a compressed chunk that a file ends inside.

A recorder killed by a power loss leaves its last chunk cut short: the ROS 1 and MCAP
readers keep that chunk's complete messages, as ``rosbag reindex`` does, which needs the
decompressed bytes of the part before the cut. The whole-chunk decompressors refuse a cut
stream, so this module decompresses it as far as it goes:

* zstd (MCAP): ``zstandard``'s streaming decompressor gives every complete zstd block
  (up to 128 KiB each) before the cut; a cut block's entropy-coded data cannot be decoded
  from one end, so it is lost.
* lz4 (ROS 1 bags and MCAP: both write one LZ4 *frame* per chunk): the frame's complete
  blocks are decompressed by the ``lz4`` library, and the cut block is decoded by
  :func:`lz4_block_prefix`, a small decoder of the LZ4 block format that stops at the cut.
  A rosbag (C++ ``roslz4``) frame holds a whole chunk in one block of up to 4 MiB, so
  without it a cut chunk gave nothing.
* bz2 (ROS 1): a bz2 stream's blocks (900 kB, a whole chunk in practice) decompress one
  by one; a cut block gives nothing.

Only the one cut chunk of a file goes through here.
"""

from __future__ import annotations

import bz2
import struct

import lz4.block
import zstandard

from analyzer.readers._common import one_line
from analyzer.readers.base import check_limit
from analyzer.readers.chunk_limits import MAX_CHUNK_BYTES

_U32 = struct.Struct("<I")
LZ4_FRAME_MAGIC = 0x184D2204
LZ4_SKIPPABLE = range(0x184D2A50, 0x184D2A60)
LZ4_WINDOW = 65536
"""How far back an LZ4 match may reach (bytes)."""
LZ4_MIN_MATCH = 4
LZ4_BLOCK_MAX = {4: 64 << 10, 5: 256 << 10, 6: 1 << 20, 7: 4 << 20}
"""A frame's largest block, by the code in its BD byte."""


class CutDataError(ValueError):
    """The compressed data before the cut is not what its compression says."""


ZSTD_PIECE = 4096
"""Compressed bytes fed at a time to zstd's streaming decompressor, which takes no
output limit: so many give at most 128 MiB (a 128 KiB block per 4-byte RLE block),
checked against the limit after each."""


def cut_prefix(compression: str, data: bytes, limit: int = MAX_CHUNK_BYTES) -> bytes:
    """The decompressed bytes that ``data`` (a chunk's compressed data, cut short) gives,
    in order from its start, hardly more than ``limit`` (the chunk's declared size:
    :mod:`analyzer.readers.chunk_limits`). ``compression`` is the chunk's: ``none`` or
    ``""`` (none), ``lz4``, ``zstd`` or ``bz2``. Raises :class:`CutDataError` for
    damaged data or an unknown compression."""
    try:
        if compression in ("none", ""):
            return bytes(data[: limit + 1])
        if compression == "lz4":
            return lz4_frame_prefix(data, limit)
        if compression == "zstd":
            return _zstd_prefix(data, limit)
        if compression == "bz2":
            return bz2.BZ2Decompressor().decompress(data, max_length=limit + 1)
    except (OSError, ValueError, RuntimeError, EOFError, zstandard.ZstdError) as err:
        check_limit(err)  # (the machine's limit is not the file's damage)
        if isinstance(err, CutDataError):
            raise
        raise CutDataError(f"its {compression} data does not decompress ({one_line(err)})") from err
    raise CutDataError(f"unsupported chunk compression {compression!r}")


def _zstd_prefix(data: bytes, limit: int) -> bytes:
    """What zstd ``data`` cut short gives, fed :data:`ZSTD_PIECE` bytes at a time until
    more than ``limit`` bytes came out."""
    stream = zstandard.ZstdDecompressor().decompressobj()
    out = bytearray()
    for at in range(0, len(data), ZSTD_PIECE):
        out += stream.decompress(data[at : at + ZSTD_PIECE])
        if len(out) > limit:
            break
    return bytes(out)


def lz4_frame_prefix(data: bytes, limit: int | None = None) -> bytes:
    """The decompressed bytes of the LZ4 frames in ``data`` up to where it ends: whole
    blocks by the ``lz4`` library, the cut block by :func:`lz4_block_prefix` (linked
    blocks with the frame's output before them as their history); with ``limit``, no
    frame is begun once more than that many bytes came out (a block is at most 4 MiB)."""
    out = bytearray()
    pos, end = 0, len(data)
    while pos + 4 <= end and (limit is None or len(out) <= limit):
        magic = _U32.unpack_from(data, pos)[0]
        if magic in LZ4_SKIPPABLE:
            if pos + 8 > end:
                break
            pos += 8 + _U32.unpack_from(data, pos + 4)[0]
            continue
        if magic != LZ4_FRAME_MAGIC:
            raise CutDataError(f"no LZ4 frame at byte {pos} of the chunk's data")
        pos = _lz4_frame(data, pos, out, limit)
    return bytes(out)


def _lz4_frame(data: bytes, pos: int, out: bytearray, limit: int | None = None) -> int:
    """Decompress the frame at ``pos`` of ``data`` onto ``out``; where the frame ends
    (``len(data)`` where it is cut, or where more than ``limit`` bytes came out)."""
    end = len(data)
    if pos + 7 > end:
        return end
    flags, block_code = data[pos + 4], (data[pos + 5] >> 4) & 7
    if flags >> 6 != 1 or block_code not in LZ4_BLOCK_MAX:
        raise CutDataError(f"LZ4 frame at byte {pos} of the chunk's data has a bad header")
    if flags & 0x01:
        raise CutDataError("LZ4 frame compressed with a dictionary (not supported)")
    linked = not flags & 0x20
    checksum = 4 if flags & 0x10 else 0
    pos += 7 + (8 if flags & 0x08 else 0)
    frame_start = len(out)
    while pos + 4 <= end and (limit is None or len(out) <= limit):
        size = _U32.unpack_from(data, pos)[0]
        pos += 4
        if size == 0:  # the end mark, then the content checksum if any
            return pos + (4 if flags & 0x04 else 0)
        stored, size = bool(size & 0x80000000), size & 0x7FFFFFFF
        block = data[pos : pos + size]
        history = bytes(out[max(frame_start, len(out) - LZ4_WINDOW) :]) if linked else b""
        if stored:
            out += block
        elif len(block) < size:
            out += lz4_block_prefix(block, history)
        else:
            try:
                out += lz4.block.decompress(
                    block, uncompressed_size=LZ4_BLOCK_MAX[block_code], dict=history
                )
            except lz4.block.LZ4BlockError as err:
                raise CutDataError(f"an LZ4 block does not decompress ({one_line(err)})") from err
        pos += size + checksum
    return end


def lz4_block_prefix(block: bytes, history: bytes = b"") -> bytes:
    """The bytes that the start of an LZ4 block (``block``, cut short) decodes to.

    An LZ4 block is a run of sequences: a token (literal count, match length), the
    literals, a two-byte match offset and the match length's extra bytes. They decode in
    order, each only from the output before it (and ``history``, the 64 KiB before the
    block where the frame links its blocks), so every sequence whole before the cut
    decodes exactly, and so do the literals of the cut one. The loop runs once per
    sequence of one block (at most 4 MiB of output); only a cut chunk's last block comes
    here, the others go to the ``lz4`` library."""
    out = bytearray(history)
    base = len(out)
    pos, end = 0, len(block)
    while pos < end:
        token = block[pos]
        pos += 1
        literals, pos = _lz4_length(block, pos, token >> 4)
        if literals < 0:
            break
        out += block[pos : pos + literals]
        pos += literals
        if pos + 2 > end:
            break
        offset = block[pos] | block[pos + 1] << 8
        pos += 2
        length, pos = _lz4_length(block, pos, token & 15)
        if length < 0:
            break
        length += LZ4_MIN_MATCH
        if offset == 0 or offset > len(out):
            raise CutDataError(f"an LZ4 match reaches before the block's data (offset {offset})")
        start = len(out) - offset
        if offset >= length:
            out += out[start : start + length]
        else:  # the match overlaps its own output: the last ``offset`` bytes repeat
            out += (out[start:] * (length // offset + 1))[:length]
    return bytes(out[base:])


def _lz4_length(block: bytes, pos: int, nibble: int) -> tuple[int, int]:
    """A token's literal count or match length (``nibble``, then extra bytes while they
    are 255) and the position after it; -1 where the block is cut inside it."""
    if nibble != 15:
        return nibble, pos
    length = nibble
    while pos < len(block):
        extra = block[pos]
        pos += 1
        length += extra
        if extra != 255:
            return length, pos
    return -1, pos


def recovered_share(count: int, got: int, size: int, *, compressed: bool) -> str:
    """What the error line of a cut chunk says was kept and lost: ``count`` complete
        messages from the first ``got`` of the chunk's ``size`` bytes (decompressed where
        ``compressed``). (The readers' line puts it after ``truncated inside the ... chunk at
    byte N (the file ends at byte M); ``: the first clause, which a run's error that stops
    leads with, names the damage only.)"""
    kept = f"its {count} complete message(s) before the cut were recovered"
    if size > 0 and got <= size:
        share = min(got * 100 // size, 99) if got < size else 100
        how = ", decompressed" if compressed else ""
        kept += f" (from the first {share} % of its {size} bytes{how})"
    return f"{kept}; the messages in the rest of the chunk are lost"

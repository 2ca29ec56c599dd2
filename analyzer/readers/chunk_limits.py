"""How much memory one chunk of an MCAP file or ROS 1 bag may take once decompressed.

A chunk says how large it is uncompressed, and the readers decompress it whole into
one buffer. Memory was therefore bounded only by what the file says: a 164 KB MCAP
file whose one zstd chunk (truthfully) declares 2.5 GiB of zeros took 2.75 GB, and an
lz4 chunk declaring 1000 bytes was decompressed with no limit at all, to gigabytes
(security review ux63, H4). So:

* a chunk that declares more than :data:`MAX_CHUNK_BYTES` uncompressed, or more than
  :data:`MAX_RATIO` times its compressed size (above :data:`RATIO_FLOOR`), is refused
  before anything is decompressed (:func:`check_chunk`): the whole file, with one line
  naming it (:class:`OversizedChunk`; in an archive of several files, that file is
  reported and skipped as a damaged one is);
* every decompressor is given the declared size as its largest output
  (:func:`decompress`): a chunk whose data holds more than it declares is damaged, and
  skipped as such, having taken no more than its declared size.
"""

from __future__ import annotations

import bz2

import lz4.frame
import zstandard

from analyzer.errors import ReaderError

MAX_CHUNK_BYTES = 1_000_000_000
"""The most a chunk may declare uncompressed (1 GB). Recorders write chunks of about
1 MB (ROS 1's ``rosbag record`` and the MCAP writers by default); the largest of the 56
chunks in the shared real data (43 MCAP files and ROS 1 bags) declares 3.0 MB. A chunk
this large is hostile or damaged, and 1 GB is still far above any real one, which a
machine that analyzes logs has to spare."""
MAX_RATIO = 1000
"""The most a chunk may declare uncompressed per byte of its compressed data. Each
message has its own time stamps and sequence number, so even a constant channel's
messages differ: the real data's compressed chunks go up to 31 times, and a chunk that
claims more than a thousand times its size is a decompression bomb (zeros compress
about 30 000 times with zstd)."""
RATIO_FLOOR = 16 << 20
"""Chunks declaring at most this many bytes (16 MiB) are not held to :data:`MAX_RATIO`:
so small a buffer costs nothing, and a short chunk of a quiet topic may compress well."""


class OversizedChunk(ReaderError):
    """A chunk that declares more than the readers decompress (:func:`check_chunk`):
    the file is not read (the error line names it, :meth:`Archive._stream`)."""


def _mb(size: int) -> str:
    """``2.7 GB``, ``21 MB``, ``812 bytes``."""
    if size >= 1_000_000_000:
        return f"{size / 1e9:,.1f} GB".replace(".0 GB", " GB")
    return f"{size / 1e6:,.0f} MB" if size >= 10_000_000 else f"{size:,} bytes"


def check_chunk(size: int, packed: int, compression: str) -> None:
    """Raise :class:`OversizedChunk` for a chunk that declares ``size`` bytes
    uncompressed from ``packed`` bytes of ``compression`` data (``""`` or ``none``:
    none) beyond :data:`MAX_CHUNK_BYTES`, or beyond :data:`MAX_RATIO` times ``packed``
    (above :data:`RATIO_FLOOR`)."""
    if size > MAX_CHUNK_BYTES:
        raise OversizedChunk(
            f"a chunk declares {_mb(size)} uncompressed, more than the {_mb(MAX_CHUNK_BYTES)} "
            "a chunk may hold (recorders write about 1 MB): damaged or built to exhaust "
            "memory; not read"
        )
    if compression not in ("", "none") and size > RATIO_FLOOR and size > MAX_RATIO * packed:
        raise OversizedChunk(
            f"a {compression} chunk declares {_mb(size)} uncompressed from {_mb(packed)}, "
            f"more than {MAX_RATIO} times its size (sensor data compresses a few dozen times "
            "at most): "
            "damaged or built to exhaust memory; not read"
        )


def decompress(compression: str, data: bytes | memoryview, size: int) -> bytes:
    """The decompressed ``data`` of a chunk declaring ``size`` bytes, never more than
    ``size + 1`` bytes of output (one more shows that there was more): zstd refuses a
    frame whose header says another size (``zstandard`` allocates what the frame says,
    whatever the limit), lz4 and bz2 stop at the limit. Raises ``ValueError`` for an
    unsupported compression, the libraries' errors for damaged data, and
    :class:`OversizedChunk` first where :func:`check_chunk` does."""
    check_chunk(size, len(data), compression)
    if compression in ("", "none"):
        return bytes(data)
    if compression == "zstd":
        said = zstandard.frame_content_size(data)
        if said not in (-1, size):  # (-1: the frame does not say)
            raise ValueError(f"its zstd frame says {said} bytes, the chunk {size}")
        # (a limit of 0 would be none: a chunk declaring 0 bytes gets 1)
        return zstandard.ZstdDecompressor().decompress(data, max_output_size=max(size, 1))
    if compression == "lz4":
        return lz4.frame.LZ4FrameDecompressor().decompress(bytes(data), max_length=size + 1)
    if compression == "bz2":
        return bz2.BZ2Decompressor().decompress(bytes(data), max_length=size + 1)
    raise ValueError(f"unsupported chunk compression {compression!r}")

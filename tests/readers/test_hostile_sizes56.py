"""Files built to exhaust the reader (security review ux63, H4 and M2): a chunk that
declares (or decompresses to) far more than any recorder writes, and a message
definition nested thousands of types deep. Each input here is a few kilobytes: the
limits are checked on what the chunk declares, and the decompressors' output limit on
a chunk that inflates to 32 MiB."""

from __future__ import annotations

import bz2
import struct
import tracemalloc
import zlib
from pathlib import Path

import lz4.frame
import pytest
import zstandard

from analyzer.errors import ReaderError
from analyzer.readers import open_archive
from analyzer.readers.chunk_limits import MAX_CHUNK_BYTES, MAX_RATIO, decompress

MAGIC = b"\x89MCAP0\r\n"
T0 = 1_700_000_000_000_000_000


def _s(text: str) -> bytes:
    b = text.encode()
    return struct.pack("<I", len(b)) + b


def _rec(op: int, body: bytes) -> bytes:
    return bytes([op]) + struct.pack("<Q", len(body)) + body


def _schema(sid: int, name: str, text: str) -> bytes:
    data = text.encode()
    body = struct.pack("<H", sid) + _s(name) + _s("ros2msg")
    return _rec(0x03, body + struct.pack("<I", len(data)) + data)


def _channel(cid: int, topic: str, sid: int) -> bytes:
    return _rec(0x04, struct.pack("<HH", cid, sid) + _s(topic) + _s("cdr") + struct.pack("<I", 0))


def _message(cid: int, seq: int, t: int, data: bytes) -> bytes:
    return _rec(0x05, struct.pack("<HIQQ", cid, seq, t, t) + data)


def _chunk(usize: int, crc: int, comp: str, data: bytes) -> bytes:
    head = struct.pack("<QQQI", T0, T0 + 10**10, usize, crc)
    return _rec(0x06, head + _s(comp) + struct.pack("<Q", len(data)) + data)


def _messages(n: int = 300, cids: tuple[int, ...] = (1, 2)) -> bytes:
    out = b""
    for i in range(n):
        for cid in cids:
            value = struct.pack("<d", (i * 7 + cid) % 11 * 0.5)
            out += _message(cid, i, T0 + i * 10_000_000, b"\x00\x01\x00\x00" + value)
    return out


def mcap(path: Path, *chunks: bytes, schemas: bytes = b"") -> Path:
    """An unindexed MCAP file (read by streaming) of two Float64 topics ``/a``, ``/b``
    and ``schemas`` (more Schema and Channel records), then ``chunks``."""
    header = _rec(0x01, _s("ros2") + _s("test"))
    floats = _schema(1, "std_msgs/msg/Float64", "float64 data\n")
    start = MAGIC + header + floats + _channel(1, "/a", 1) + _channel(2, "/b", 1) + schemas
    tail = _rec(0x0F, struct.pack("<I", 0)) + _rec(0x02, struct.pack("<QQI", 0, 0, 0)) + MAGIC
    path.write_bytes(start + b"".join(chunks) + tail)
    return path


def good_chunk() -> bytes:
    records = _messages()
    return _chunk(len(records), zlib.crc32(records), "zstd", zstandard.compress(records))


def test_a_chunk_declaring_a_terabyte_refuses_the_file_in_one_line(tmp_path: Path) -> None:
    """Before: ``no numeric channel found (chunk ...: MemoryError; skipped)`` where the
    allocation failed at once, and the whole declared size taken where it did not."""
    data = zstandard.ZstdCompressor(write_content_size=False).compress(_messages())
    path = mcap(tmp_path / "tb.mcap", good_chunk(), _chunk(1 << 40, 0, "zstd", data))
    with pytest.raises(ReaderError) as err:
        list(open_archive(path).chunks("log"))
    assert str(err.value) == (
        f"{path}: a chunk declares 1,099.5 GB uncompressed, more than the 1 GB a chunk may "
        "hold (recorders write about 1 MB): damaged or built to exhaust memory; not read"
    )


def test_a_chunk_that_claims_too_high_a_ratio_is_refused(tmp_path: Path) -> None:
    """32 MiB of zeros in 1 KB of zstd (truthfully declared: the limit is on the ratio,
    which no sensor data reaches). Before, it was decompressed whole."""
    size = 32 << 20
    data = zstandard.compress(bytes(size))
    assert size > MAX_RATIO * len(data)
    path = mcap(tmp_path / "ratio.mcap", good_chunk(), _chunk(size, 0, "zstd", data))
    with pytest.raises(ReaderError, match=r"ratio\.mcap: a zstd chunk declares 34 MB .* more than"):
        list(open_archive(path).chunks("log"))


def test_one_refused_file_of_an_archive_is_reported_and_the_others_read(tmp_path: Path) -> None:
    folder = tmp_path / "arch"
    folder.mkdir()
    mcap(folder / "a.mcap", good_chunk())
    data = zstandard.ZstdCompressor(write_content_size=False).compress(b"x")
    mcap(folder / "b.mcap", _chunk(1 << 40, 0, "zstd", data))
    archive = open_archive(folder)
    samples = sum(c.values.size for c in archive.chunks("log"))
    assert samples == 600
    (bad,) = [i for i in archive.inputs if i.errors]
    assert bad.path.name == "b.mcap"
    assert any("a chunk declares 1,099.5 GB uncompressed" in e for e in bad.errors)


def test_an_lz4_chunk_inflating_past_its_declared_size_stops_at_it(tmp_path: Path) -> None:
    """An lz4 chunk declaring 1000 bytes whose data inflates to 32 MiB: skipped as damaged,
    having taken about its declared size. Before, ``lz4.frame.decompress`` had no limit
    (a 26 MB file took 3.5 GB before a 4 GB limit stopped it)."""
    data = lz4.frame.compress(bytes(32 << 20))
    path = mcap(tmp_path / "lz4.mcap", good_chunk(), _chunk(1000, 0, "lz4", data))
    archive = open_archive(path)
    tracemalloc.start()
    try:
        samples = sum(c.values.size for c in archive.chunks("log"))
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert samples == 600
    assert peak < 16 << 20, f"{peak / 1e6:.0f} MB taken"
    (info,) = archive.inputs
    said = "its data decompresses to more than the 1000 bytes it declares"
    assert any(said in e for e in info.errors)


@pytest.mark.parametrize("compression", ["lz4", "bz2", "zstd"])
def test_the_decompressors_stop_one_byte_past_the_declared_size(compression: str) -> None:
    src = bytes(4 << 20)
    packed = {
        "lz4": lz4.frame.compress,
        "bz2": bz2.compress,
        "zstd": zstandard.ZstdCompressor(write_content_size=False).compress,
    }[compression](src)
    if compression == "zstd":
        with pytest.raises(zstandard.ZstdError):
            decompress(compression, packed, 1000)
    else:
        assert len(decompress(compression, packed, 1000)) == 1001
    assert decompress(compression, packed, len(src)) == src
    assert MAX_CHUNK_BYTES == 1_000_000_000


def test_a_zstd_frame_that_says_another_size_than_its_chunk_is_damage() -> None:
    """``zstandard`` allocates what the frame header says, whatever the output limit."""
    with pytest.raises(ValueError, match="its zstd frame says 4194304 bytes, the chunk 1000"):
        decompress("zstd", zstandard.compress(bytes(4 << 20)), 1000)


def test_a_definition_nested_thousands_deep_skips_its_topic_only(tmp_path: Path) -> None:
    """3000 nested types on ``/x``: that topic is skipped with a note, ``/a`` and ``/b``
    are read. Before: "maximum recursion depth exceeded", the whole file lost."""
    sep = "\n" + "=" * 80 + "\n"
    depth = 3000
    parts = ["pkg/T1 t"] + [f"MSG: pkg/T{i}\npkg/T{i + 1} t" for i in range(1, depth)]
    text = sep.join([*parts, f"MSG: pkg/T{depth}\nfloat64 v"])
    records = _messages(cids=(1, 2, 3))
    path = mcap(
        tmp_path / "deep.mcap",
        _chunk(len(records), 0, "", records),
        schemas=_schema(2, "pkg/msg/A", text) + _channel(3, "/x", 2),
    )
    archive = open_archive(path)
    assert sum(c.values.size for c in archive.chunks("log")) == 600
    (info,) = archive.inputs
    assert info.errors == [
        "/x: its message definition nests types more than 64 deep, or within themselves "
        "(real ones nest a few); skipped"
    ]


def test_a_definition_nested_64_deep_is_read(tmp_path: Path) -> None:
    sep = "\n" + "=" * 80 + "\n"
    depth = 63  # (the top type, then 63 nested ones: 64 levels)
    parts = ["pkg/T1 t"] + [f"MSG: pkg/T{i}\npkg/T{i + 1} t" for i in range(1, depth)]
    text = sep.join([*parts, f"MSG: pkg/T{depth}\nfloat64 v"])
    records = _messages(cids=(1, 2, 3))
    path = mcap(
        tmp_path / "ok.mcap",
        _chunk(len(records), 0, "", records),
        schemas=_schema(2, "pkg/msg/A", text) + _channel(3, "/x", 2),
    )
    archive = open_archive(path)
    assert sum(c.values.size for c in archive.chunks("log")) == 900
    assert archive.inputs[0].errors == []


@pytest.mark.parametrize("compression", ["bz2", "lz4"])
def test_a_ros1_chunk_declaring_4_gb_refuses_the_bag(tmp_path: Path, compression: str) -> None:
    """A ROS 1 bag whose chunks' ``size`` field says 4.3 GB (its largest u32): refused in
    one line before anything is decompressed. Before, each chunk was decompressed whole,
    with no limit (``bz2.decompress``, ``lz4.frame.decompress``), then skipped."""
    import numpy as np

    from analyzer.writers import write_archive

    path = tmp_path / "big.bag"
    t = np.arange(2000, dtype=np.int64) * 10_000_000 + T0
    write_archive(path, "ros1bag", t, {"a": np.sin(t / 1e9)}, compression=compression)
    raw = bytearray(path.read_bytes())
    field = b"\t\x00\x00\x00size="  # (the field's length, 9, then its name)
    at = raw.find(field)
    assert at > 0, "no chunk size field found"
    while at > 0:
        raw[at + len(field) : at + len(field) + 4] = b"\xff\xff\xff\xff"
        at = raw.find(field, at + 1)
    patched = raw
    path.write_bytes(bytes(patched))
    with pytest.raises(ReaderError, match=r"big\.bag: a chunk declares 4\.3 GB uncompressed"):
        list(open_archive(path).chunks("log"))

"""A ROS 1 bag cut short (archive probe 31): the complete messages of the chunk the file
ends inside are recovered, as ``rosbag reindex`` does, and the error says how much was
read. Before, the whole partial chunk was lost (a bag cut at 60 % inside its one chunk
gave no message, with an error saying "the messages before it were read")."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.cli import main
from analyzer.readers.ros1_reader import Ros1BagReader
from analyzer.timeutil import spoken_duration

ROS1 = get_typestore(Stores.ROS1_NOETIC)
FLOAT64 = "std_msgs/msg/Float64"
PERIOD_NS = 10_000_000
CHUNK_POS = 4109
"""Where rosbags puts the first chunk (after the magic and the 4096-byte bag header)."""


def _bag(
    path: Path, n: int = 3000, *, compression: str | None = None, threshold: int = 1 << 20
) -> Path:
    """``n`` messages on each of ``/a`` (value i) and ``/b`` (value -i), interleaved,
    every 10 ms from :data:`T0`, in chunks of about ``threshold`` bytes."""
    writer = Ros1Writer(path)
    writer.chunk_threshold = threshold
    if compression is not None:
        writer.set_compression(getattr(Ros1Writer.CompressionFormat, compression.upper()))
    with writer:
        a = writer.add_connection("/a", FLOAT64, typestore=ROS1)
        b = writer.add_connection("/b", FLOAT64, typestore=ROS1)
        for i in range(n):
            t = T0 + i * PERIOD_NS
            writer.write(a, t, struct.pack("<d", float(i)))
            writer.write(b, t, struct.pack("<d", -float(i)))
    return path


def _chunks(path: Path) -> list[tuple[int, int, int]]:
    """(record position, data start, data end) of every chunk record of a whole bag."""
    data = path.read_bytes()
    out = []
    pos = CHUNK_POS
    while pos + 4 <= len(data):
        header_len = struct.unpack_from("<I", data, pos)[0]
        header = data[pos + 4 : pos + 4 + header_len]
        data_len = struct.unpack_from("<I", data, pos + 4 + header_len)[0]
        start = pos + 8 + header_len
        if b"op=\x05" in header:
            out.append((pos, start, start + data_len))
        elif b"op=\x07" in header or b"op=\x06" in header:
            break  # the index section
        pos = start + data_len
    return out


def _cut(path: Path, size: int, name: str) -> Path:
    out = path.with_name(name)
    out.write_bytes(path.read_bytes()[:size])
    return out


def _read(path: Path) -> tuple[dict[str, np.ndarray], list[str]]:
    reader = Ros1BagReader(path)
    samples = collect(reader.chunks())
    return {name: v for name, (_, v) in samples.items()}, reader.info.errors


def _prefix(values: dict[str, np.ndarray]) -> int:
    """How many messages of ``/a`` were read, checking that ``/a`` and ``/b`` hold the
    first ones, in order, without a hole."""
    a, b = values.get("/a.data", np.empty(0)), values.get("/b.data", np.empty(0))
    assert np.array_equal(a, np.arange(a.size)), a
    assert np.array_equal(b, -np.arange(b.size)), b
    assert a.size - b.size in (0, 1)  # /a's message i is written before /b's
    return int(a.size + b.size)


def _said(errors: list[str], count: int) -> None:
    """The error line names the messages read and the time they reach."""
    last_ns = (count - 1) // 2 * PERIOD_NS
    assert errors[-1].endswith(
        f"; {count} message(s) read in all, up to {spoken_duration(last_ns / 1e9)} after the first"
    ), errors


def test_cut_inside_the_only_chunk_keeps_its_complete_messages(tmp_path: Path) -> None:
    """One uncompressed chunk, the file cut at 60 %: no message was read."""
    full = _bag(tmp_path / "full.bag")
    ((pos, start, end),) = _chunks(full)
    size = start + (end - start) * 60 // 100
    values, errors = _read(_cut(full, size, "cut.bag"))
    count = _prefix(values)
    assert 0.59 * 6000 < count < 0.6 * 6000
    assert errors[0] == "bag index lies past the end of the file (truncated?); read sequentially"
    assert errors[1].startswith(
        f"truncated inside the uncompressed chunk that starts at byte {pos} (the file ends at byte "
        f"{size}); its {count} complete message(s) before the cut were recovered"
    )
    _said(errors, count)


def test_a_message_is_recovered_exactly_when_its_record_is_whole(tmp_path: Path) -> None:
    """Cut at the last byte of /a's message 1234: it is read; one byte earlier: not."""
    full = _bag(tmp_path / "full.bag")
    data = full.read_bytes()
    end = data.index(struct.pack("<d", 1234.0)) + 8
    values, _ = _read(_cut(full, end, "whole.bag"))
    assert _prefix(values) == 2 * 1234 + 1 and values["/a.data"][-1] == 1234.0
    values, _ = _read(_cut(full, end - 1, "short.bag"))
    assert _prefix(values) == 2 * 1234 and values["/a.data"][-1] == 1233.0


def test_cut_in_a_later_chunk_keeps_the_chunks_before_and_its_part(tmp_path: Path) -> None:
    """Many small chunks, cut in the middle of /a's message 2800: the data ended at the
    last whole chunk."""
    full = _bag(tmp_path / "full.bag", threshold=16 << 10)
    data = full.read_bytes()
    size = data.index(struct.pack("<d", 2800.0)) + 4
    pos = max(p for p, _, _ in _chunks(full) if p < size)
    assert pos > CHUNK_POS
    values, errors = _read(_cut(full, size, "cut.bag"))
    count = _prefix(values)
    assert count == 2 * 2800
    before = _prefix(_read(_cut(full, pos, "whole_chunks.bag"))[0])
    assert 0 < before < count
    assert errors[-1].startswith(
        f"truncated inside the uncompressed chunk that starts at byte {pos} (the file ends at "
        f"byte {size}); "
        f"its {count - before} complete message(s) before the cut were recovered"
    )
    _said(errors, count)


def test_cut_lz4_chunk_keeps_its_whole_blocks(tmp_path: Path) -> None:
    """An lz4 chunk decompresses block by block: the blocks before the cut are read."""
    full = _bag(tmp_path / "full.bag", n=20_000, compression="lz4", threshold=1 << 24)
    ((pos, start, end),) = _chunks(full)
    size = start + (end - start) * 60 // 100
    values, errors = _read(_cut(full, size, "cut.bag"))
    count = _prefix(values)
    assert 0 < count < 40_000
    assert errors[-1].startswith(
        f"truncated inside the lz4-compressed chunk that starts at byte {pos} (the file ends "
        f"at byte {size}); its {count} complete message(s) before the cut were recovered"
    )
    _said(errors, count)


def test_cut_bz2_chunk_says_its_messages_are_lost(tmp_path: Path) -> None:
    """A bz2 chunk is one bz2 block: cut, none of it decompresses; the chunks before it
    are read, and the error says which chunk was lost and why."""
    full = _bag(tmp_path / "full.bag", compression="bz2", threshold=16 << 10)
    pos, start, end = _chunks(full)[-2]
    size = (start + end) // 2
    values, errors = _read(_cut(full, size, "cut.bag"))
    count = _prefix(values)
    assert count == _prefix(_read(_cut(full, pos, "whole_chunks.bag"))[0]) > 0
    assert errors[-1] == (
        f"truncated inside the bz2-compressed chunk that starts at byte {pos} (the file ends "
        f"at byte {size}); its bz2-compressed data holds no complete block before the cut, so none "
        f"of its messages can be recovered; {count} message(s) read in all, up to "
        f"{spoken_duration((count - 1) // 2 * PERIOD_NS / 1e9)} after the first"
    )


def test_cut_before_any_message_says_none_was_read(tmp_path: Path, capsys) -> None:
    """Cut inside the first chunk's header: "the messages before it were read" was said
    of none."""
    full = _bag(tmp_path / "full.bag")
    cut = _cut(full, CHUNK_POS + 10, "cut.bag")
    values, errors = _read(cut)
    assert values == {}
    assert errors[-1] == (
        f"truncated or damaged at byte {CHUNK_POS} (truncated record); no message before it "
        "could be read"
    )
    assert main(["inspect", str(cut)]) == 2
    assert "no message before it could be read" in capsys.readouterr().err


def test_records_of_a_chunk_never_closed_are_read(tmp_path: Path) -> None:
    """rosbag writes a chunk's header with sizes of 0 and completes it when the chunk
    closes: a recording killed meanwhile leaves the chunk's records loose after an empty
    chunk record, without an index. They are read."""
    full = _bag(tmp_path / "full.bag", n=500)
    data = bytearray(full.read_bytes())
    header_len = struct.unpack_from("<I", data, CHUNK_POS)[0]
    header_end = CHUNK_POS + 4 + header_len
    data_len = struct.unpack_from("<I", data, header_end)[0]
    size_at = data.index(b"size=", CHUNK_POS, header_end) + 5
    struct.pack_into("<I", data, size_at, 0)
    struct.pack_into("<I", data, header_end, 0)
    struct.pack_into("<Q", data, data.index(b"index_pos=") + 10, 0)
    killed = tmp_path / "killed.bag"
    killed.write_bytes(bytes(data[: header_end + 4 + data_len]))  # no index data, no index
    values, errors = _read(killed)
    assert _prefix(values) == 1000
    assert errors == [
        "bag is not indexed (recording not closed?); read sequentially",
        f"file ends at byte {header_end + 4 + data_len} without an index section; the 1000 "
        "messages before it were read, up to 5.0 s after the first",
    ]


@pytest.mark.parametrize("compression", [None, "lz4", "bz2"])
def test_whole_bags_read_as_before(tmp_path: Path, compression: str | None) -> None:
    values, errors = _read(_bag(tmp_path / "full.bag", compression=compression))
    assert _prefix(values) == 6000 and errors == []

"""A file cut short inside a compressed chunk (a new user's audit, items 2 and 3): the
chunk is decompressed as far as its data goes and its complete messages are kept, and
the error says how many and that the rest of the chunk is lost.

Before, a ROS 1 bag whose lz4 chunk is one LZ4 block (rosbag's ``roslz4`` writes blocks
of up to 4 MiB: ``example-lz4.bag`` cut at 200 kB) and an MCAP file cut inside its zstd
or lz4 chunk (``nav2_turtlebot.mcap``, one chunk, cut at 300 kB) gave no message at all:
the whole-chunk decompressors refuse a cut stream. The audit measured 7 613 and 6 540
complete messages in those cut chunks; the readers now keep exactly those.
"""

from __future__ import annotations

import struct
from pathlib import Path

import lz4.frame
import numpy as np
import pytest
import zstandard
from mcap.records import Message
from mcap.stream_reader import StreamReader
from readers_helpers import T0, collect, read, synthetic
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.cli import main
from analyzer.readers.ros1_reader import Ros1BagReader
from analyzer.timeutil import spoken_duration
from analyzer.writers import write_archive

ROS1 = get_typestore(Stores.ROS1_NOETIC)
FLOAT64 = "std_msgs/msg/Float64"
PERIOD_NS = 10_000_000
CHUNK_POS = 4109
"""Where rosbags puts the first chunk (after the magic and the 4096-byte bag header)."""
OP_CHUNK = 6
"""An MCAP Chunk record's opcode."""


# ---------------------------------------------------------------------- ROS 1 bags


def _bag(path: Path, n: int, walks: bool = False) -> Path:
    """``n`` messages on each of ``/a`` (value i) and ``/b`` (value -i), interleaved,
    every 10 ms from :data:`T0`, in one uncompressed chunk; with ``walks``, two
    independent random walks instead."""
    values = np.stack([np.arange(n, dtype=float), -np.arange(n, dtype=float)])
    if walks:
        values = np.cumsum(np.random.default_rng(5).normal(size=(2, n)), axis=1)
    writer = Ros1Writer(path)
    writer.chunk_threshold = 1 << 26
    with writer:
        a = writer.add_connection("/a", FLOAT64, typestore=ROS1)
        b = writer.add_connection("/b", FLOAT64, typestore=ROS1)
        for i in range(n):
            t = T0 + i * PERIOD_NS
            writer.write(a, t, struct.pack("<d", values[0, i]))
            writer.write(b, t, struct.pack("<d", values[1, i]))
    return path


def _header(fields: dict[str, bytes]) -> bytes:
    body = b"".join(
        struct.pack("<I", len(k) + 1 + len(v)) + k.encode() + b"=" + v for k, v in fields.items()
    )
    return struct.pack("<I", len(body)) + body


def _roslz4_cut(full: Path, out: Path, short: int) -> tuple[Path, int, int, int]:
    """``full``'s one chunk compressed as rosbag's ``roslz4`` does (one LZ4 frame of
    independent blocks of up to 4 MiB, content checksum: one block for the chunk), the
    file cut ``short`` bytes before the chunk's data ends (the index after it lost).
    Returns the cut file, the chunk's position, the file's size and the chunk's size."""
    data = full.read_bytes()
    header_len = struct.unpack_from("<I", data, CHUNK_POS)[0]
    header = data[CHUNK_POS + 4 : CHUNK_POS + 4 + header_len]
    assert b"compression=none" in header
    at = CHUNK_POS + 4 + header_len
    records = data[at + 4 : at + 4 + struct.unpack_from("<I", data, at)[0]]
    frame = lz4.frame.compress(
        records,
        block_size=lz4.frame.BLOCKSIZE_MAX4MB,
        block_linked=False,
        content_checksum=True,
    )
    fields = {"op": b"\x05", "compression": b"lz4", "size": struct.pack("<I", len(records))}
    chunk = _header(fields) + struct.pack("<I", len(frame)) + frame
    cut = (data[:CHUNK_POS] + chunk)[: -short - 8]  # (the end mark and content checksum)
    out.write_bytes(cut)
    return out, CHUNK_POS, len(cut), len(records)


def _values(path: Path) -> tuple[np.ndarray, np.ndarray, list[str]]:
    reader = Ros1BagReader(path)
    samples = collect(reader.chunks())
    a = samples.get("/a.data", (None, np.empty(0)))[1]
    b = samples.get("/b.data", (None, np.empty(0)))[1]
    return a, b, reader.info.errors


def test_a_roslz4_chunk_cut_keeps_its_complete_messages(tmp_path: Path) -> None:
    """One 4 MiB LZ4 block per chunk, as ``roslz4`` writes: cut at 60 % of its data,
    the messages before the cut are read (before: none, "holds no complete block")."""
    full = _bag(tmp_path / "full.bag", 20_000)
    whole, pos, _, size = _roslz4_cut(full, tmp_path / "whole.bag", 0)
    compressed = whole.stat().st_size - pos
    cut, _, end, _ = _roslz4_cut(full, tmp_path / "cut.bag", compressed * 40 // 100)
    a, b, errors = _values(cut)
    assert np.array_equal(a, np.arange(a.size)) and np.array_equal(b, -np.arange(b.size))
    count = a.size + b.size
    assert 0.4 * 40_000 < count < 40_000
    assert errors[0] == "bag index lies past the end of the file (truncated?); read sequentially"
    assert errors[1].startswith(
        f"truncated inside the lz4-compressed chunk that starts at byte {pos} (the file ends "
        f"at byte {end}); its {count} complete message(s) before the cut were recovered (from the "
        "first "
    )
    lost = (
        f" % of its {size} bytes, decompressed); the messages in the rest of the chunk are lost; "
    )
    assert lost in errors[1]
    assert errors[1].endswith(
        f"; {count} message(s) read in all, up to "
        f"{spoken_duration((count - 1) // 2 * PERIOD_NS / 1e9)} after the first"
    )


def test_a_roslz4_chunk_cut_one_byte_short_loses_only_its_last_message(tmp_path: Path) -> None:
    full = _bag(tmp_path / "full.bag", 3000)
    cut, _, _, _ = _roslz4_cut(full, tmp_path / "cut.bag", 1)
    a, b, errors = _values(cut)
    assert np.array_equal(a, np.arange(3000)) and np.array_equal(b, -np.arange(2999))
    assert "its 5999 complete message(s) before the cut were recovered" in errors[1]


def test_run_on_a_cut_roslz4_bag_warns_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """``run`` goes on with what was kept, and says so on stderr, naming the file."""
    full = _bag(tmp_path / "full.bag", 20_000, walks=True)
    whole, pos, _, _ = _roslz4_cut(full, tmp_path / "whole.bag", 0)
    cut, _, _, _ = _roslz4_cut(full, tmp_path / "cut.bag", (whole.stat().st_size - pos) // 3)
    out = str(tmp_path / "o")
    code = main(["run", str(cut), "--out", out, "--train", "0:60", "--no-progress"])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    (line,) = [x for x in err.splitlines() if "truncated inside" in x]
    assert line.startswith(f"analyzer: warning: {cut}: truncated inside the lz4-compressed chunk")
    assert "the messages in the rest of the chunk are lost" in line


# ---------------------------------------------------------------------- MCAP


def _one_chunk_mcap(path: Path, compression: str) -> tuple[dict[str, str], np.ndarray, dict]:
    t, data = synthetic(6000, channels=3)
    names = write_archive(path, "mcap", t, data, compression=compression, chunk_size=1 << 26)
    return names, t, data


def _chunk_at(data: bytes) -> tuple[int, int, int]:
    """(position, start of its compressed data, end of the record) of the file's one
    Chunk record."""
    pos = 8
    while data[pos] != OP_CHUNK:
        pos += 9 + struct.unpack_from("<Q", data, pos + 1)[0]
    comp_len = struct.unpack_from("<I", data, pos + 9 + 28)[0]
    start = pos + 9 + 32 + comp_len + 8
    return pos, start, pos + 9 + struct.unpack_from("<Q", data, pos + 1)[0]


def _expected_messages(data: bytes, compression: str, start: int) -> int:
    """How many whole Message records the cut chunk's data decompresses to, counted with
    the libraries themselves: zstandard's streaming decompressor, or the whole frame
    decompressed and cut to the records before the compressed cut's last whole LZ4
    block (a lower bound)."""
    if compression == "zstd":
        records = zstandard.ZstdDecompressor().decompressobj().decompress(data[start:])
    elif compression == "none":
        records = data[start:]
    else:
        records = lz4.frame.LZ4FrameDecompressor().decompress(data[start:])
    count = pos = 0
    while pos + 9 <= len(records):
        end = pos + 9 + struct.unpack_from("<Q", records, pos + 1)[0]
        if end > len(records):
            break
        count += records[pos] == 5  # a Message record
        pos = end
    return count


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_an_mcap_cut_inside_its_one_chunk_keeps_its_complete_messages(
    tmp_path: Path, compression: str
) -> None:
    """Before: ``truncated or damaged at byte N (unexpected end of file); the 0 messages
    before it were read``."""
    names, t, data = _one_chunk_mcap(tmp_path / "full.mcap", compression)
    whole = (tmp_path / "full.mcap").read_bytes()
    pos, start, end = _chunk_at(whole)
    size = start + (end - start) * 7 // 10
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[:size])
    samples, info = read(cut)
    count = 0
    for key, name in names.items():
        t_got, v_got = samples[name]
        np.testing.assert_array_equal(t_got, t[: t_got.size])
        np.testing.assert_array_equal(v_got, data[key][: v_got.size])
        count += t_got.size
    expected = _expected_messages(whole[:size], compression, start)
    if compression == "lz4":  # the cut LZ4 block's whole sequences too
        assert count > expected
    else:
        assert count == expected > 0
    assert count < 3 * 6000
    (line,) = [e for e in info.errors if "truncated" in e]
    kind = "uncompressed" if compression == "none" else f"{compression}-compressed"
    assert line.startswith(
        f"truncated inside the {kind} chunk that starts at byte {pos} (the file ends at byte "
        f"{size}); its "
        f"{count} complete message(s) before the cut were recovered (from the first "
    )
    how = "" if compression == "none" else ", decompressed"
    assert line.endswith(
        f" bytes{how}); the messages in the rest of the chunk are lost; {count} "
        "message(s) read in all"
    )


def test_an_lz4_mcap_chunk_cut_five_bytes_short_loses_only_its_last_message(
    tmp_path: Path,
) -> None:
    """The chunk's frame ends with a 4-byte end mark; one byte more is its last literal."""
    names, t, _ = _one_chunk_mcap(tmp_path / "full.mcap", "lz4")
    whole = (tmp_path / "full.mcap").read_bytes()
    _, _, end = _chunk_at(whole)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: end - 5])
    samples, _ = read(cut)
    got = sorted(samples[name][0].size for name in names.values())
    assert got == [5999, 6000, 6000]


def test_the_messages_match_the_reference_reader_where_it_reads_them(tmp_path: Path) -> None:
    """The chunks before a cut one are read as the mcap library reads them, and the
    cut one's complete messages after them (lz4: a 64 KiB chunk is one zstd block)."""
    t, data = synthetic(20_000, channels=2)
    path = tmp_path / "full.mcap"
    names = write_archive(path, "mcap", t, data, compression="lz4", chunk_size=64 * 1024)
    whole = path.read_bytes()
    pos, chunks = 8, []
    while whole[pos] != 0x0F:  # (DataEnd)
        chunks += [pos] if whole[pos] == OP_CHUNK else []
        pos += 9 + struct.unpack_from("<Q", whole, pos + 1)[0]
    assert len(chunks) > 4
    middle = chunks[len(chunks) // 2]
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: middle + 9 + struct.unpack_from("<Q", whole, middle + 1)[0] // 2])
    reference = 0
    with cut.open("rb") as handle:
        try:
            for record in StreamReader(handle).records:
                reference += isinstance(record, Message)
        except Exception:  # noqa: BLE001 - the reference stops at the damage
            pass
    samples, info = read(cut)
    for key, name in names.items():
        t_got, v_got = samples[name]
        np.testing.assert_array_equal(t_got, t[: t_got.size])
        np.testing.assert_array_equal(v_got, data[key][: v_got.size])
    count = sum(samples[name][0].size for name in names.values())
    assert count > reference > 0
    assert any(e.startswith("truncated inside the lz4-compressed chunk") for e in info.errors)


def test_a_zstd_chunk_cut_in_its_first_block_says_so_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Nothing can be had: ``run`` and ``export`` lead their error with the cut, the
    cause (before: ``no numeric channel found (truncated or damaged ...)``)."""
    _one_chunk_mcap(tmp_path / "full.mcap", "zstd")
    whole = (tmp_path / "full.mcap").read_bytes()
    _, start, _ = _chunk_at(whole)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole[: start + 1000])
    assert main(["run", str(cut), "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(
        f"analyzer: error: {cut}: truncated inside the zstd-compressed chunk that starts at byte "
    )
    assert (
        "its zstd-compressed data holds no complete block before the cut, so none of its "
        "messages can be recovered; 0 message(s) read in all, so no numeric channel found"
    ) in err
    assert main(["export", str(cut), "--out", str(tmp_path / "o.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"analyzer: error: {cut}: truncated inside the zstd-compressed chunk")
    assert "so no numeric channel to export" in err


@pytest.mark.realdata
@pytest.mark.parametrize(
    ("name", "size", "kept"),
    [
        ("ros1/rosbag.js/example-lz4.bag", 200_000, 7613),
        ("mcap/evo/nav2_turtlebot.mcap", 300_000, 6540),
    ],
)
def test_the_audits_cut_files(
    realdata: Path, tmp_path: Path, name: str, size: int, kept: int
) -> None:
    """The audit's cuts keep the messages it counted, each as in the whole file."""
    cut = tmp_path / Path(name).name
    cut.write_bytes((realdata / name).read_bytes()[:size])
    samples, info = read(cut)
    whole, _ = read(realdata / name)
    assert any(
        f"its {kept} complete message(s) before the cut were recovered" in e for e in info.errors
    )
    for channel, (t_got, v_got) in samples.items():
        t_all, v_all = whole[channel]
        np.testing.assert_array_equal(t_got, t_all[: t_got.size])
        np.testing.assert_array_equal(v_got, v_all[: v_got.size])

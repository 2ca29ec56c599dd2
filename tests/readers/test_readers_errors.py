"""Error paths: every problem is one ReaderError line naming the file, or, where the rest
is readable, an entry in ``info.errors`` after reading what can be read."""

from __future__ import annotations

import os
import sqlite3
import struct
from pathlib import Path

import numpy as np
import pytest
from mcap.records import Message as McapMessage
from mcap.records import MessageIndex
from mcap.stream_reader import StreamReader
from readers_helpers import collect, synthetic
from rosbags.rosbag2 import Writer as Bag2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from analyzer.errors import ReaderError
from analyzer.readers import detect_format, open_archive, open_input
from analyzer.types import Format
from analyzer.writers import write_archive, write_ros2_bag


def one_line(err: pytest.ExceptionInfo[ReaderError], path: Path) -> str:
    message = str(err.value)
    assert "\n" not in message
    assert str(path) in message
    return message


def test_missing_path(tmp_path: Path) -> None:
    path = tmp_path / "nope.mcap"
    with pytest.raises(ReaderError, match="no such file or directory") as err:
        open_input(path)
    one_line(err, path)
    with pytest.raises(ReaderError, match="no such file or directory"):
        open_archive([path])


def test_unknown_format(tmp_path: Path) -> None:
    path = tmp_path / "notes.xyz"
    path.write_text("hello\n")
    with pytest.raises(ReaderError, match="unknown format") as err:
        open_input(path)
    one_line(err, path)


@pytest.mark.parametrize("name", ["empty.mcap", "empty.bag", "empty.csv", "empty.db3"])
def test_zero_byte_file(tmp_path: Path, name: str) -> None:
    path = tmp_path / name
    path.write_bytes(b"")
    with pytest.raises(ReaderError, match=r"empty file \(0 bytes\)") as err:
        open_input(path)
    one_line(err, path)


def lfs_pointer_text(size: int) -> str:
    """What a repository cloned without ``git lfs`` holds in place of a tracked file."""
    oid = "f720b819f6ca73301cd793d7c19e686c4779ca0daa1754ab58c086e435c55a32"
    return f"version https://git-lfs.github.com/spec/v1\noid sha256:{oid}\nsize {size}\n"


@pytest.mark.parametrize("name", ["a.mcap", "a.bag", "a.db3", "a.csv", "a.csv.gz", "a"])
def test_git_lfs_pointer_is_named(tmp_path: Path, name: str) -> None:
    # each reader's own error ("bad magic", "not a database", "no numeric column") would
    # not tell the user that the file was never fetched
    path = tmp_path / name
    path.write_text(lfs_pointer_text(53987758))
    with pytest.raises(ReaderError, match=r"Git LFS pointer \(to a 53987758-byte file\)") as err:
        open_input(path)
    assert "git lfs pull" in one_line(err, path)


def test_git_lfs_pointer_in_a_ros2_bag_and_in_an_archive(tmp_path: Path) -> None:
    t, data = synthetic(200)
    bag = tmp_path / "bag"
    write_ros2_bag(bag, t, data)
    (storage,) = bag.glob("*.db3")
    storage.write_text(lfs_pointer_text(4096))
    with pytest.raises(ReaderError, match="Git LFS pointer") as err:
        open_input(bag)
    assert str(storage) in one_line(err, bag)
    # a pointer among an archive's files is reported and skipped, the rest is read
    folder = tmp_path / "hours"
    folder.mkdir()
    write_archive(folder / "h0.mcap", "mcap", t, data)
    (folder / "h1.mcap").write_text(lfs_pointer_text(4096))
    archive = open_archive(folder)
    failed = [info for info in archive.inputs if info.errors]
    assert [info.path.name for info in failed] == ["h1.mcap"]
    assert "Git LFS pointer" in failed[0].errors[0]
    assert collect(archive.chunks())


def test_crlf_mangled_mcap(tmp_path: Path) -> None:
    t, data = synthetic(200)
    good = tmp_path / "good.mcap"
    write_archive(good, "mcap", t, data)
    bad = tmp_path / "mangled.mcap"
    bad.write_bytes(good.read_bytes().replace(b"\r\n", b"\n"))
    with pytest.raises(
        ReaderError,
        match=r"not an MCAP file \(bad magic 89 4d 43 41 50 30 0a "
        r".*possibly mangled by a CRLF conversion",
    ) as err:
        open_input(bad)
    one_line(err, bad)


def test_garbage_with_known_suffixes(tmp_path: Path) -> None:
    mcap = tmp_path / "garbage.mcap"
    mcap.write_bytes(b"\x00\x01garbage" * 10)
    with pytest.raises(ReaderError, match=r"not an MCAP file \(bad magic 00 01 67") as err:
        open_input(mcap)
    assert "CRLF" not in str(err.value)
    bag = tmp_path / "garbage.bag"
    bag.write_bytes(b"garbage" * 10)
    with pytest.raises(ReaderError, match="not a ROS 1 bag"):
        open_input(bag)


def test_truncated_mcap_reads_the_readable_part(tmp_path: Path) -> None:
    t, data = synthetic(20_000, channels=2)
    path = tmp_path / "full.mcap"
    names = write_archive(path, "mcap", t, data, chunk_size=32 * 1024)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size * 6 // 10])
    reader = open_input(cut)
    got = collect(reader.chunks())
    assert any("truncated" in e for e in reader.info.errors), reader.info.errors
    t_got, v_got = got[names["s1"]]
    assert 0 < t_got.size < t.size
    np.testing.assert_array_equal(v_got, data["s1"][: t_got.size])
    np.testing.assert_array_equal(t_got, t[: t_got.size])
    assert reader.start_ns() == t[0]


def test_a_cut_among_a_chunks_message_indexes_keeps_every_channel(tmp_path: Path) -> None:
    """CLI audit: cut among the MessageIndex records after a complete chunk, the chunk
    was read for the channels whose index survived only (building_additive.mcap cut at
    1.6 MB: three of five channels lost their last 11 s; at 1.1 MB four lost half).
    At every cut, each channel has what the reference reader reads: the complete chunks'
    messages."""
    t, data = synthetic(6_000, channels=5)
    path = tmp_path / "full.mcap"
    names = write_archive(path, "mcap", t, data, chunk_size=16 * 1024)
    whole = path.read_bytes()
    # the MessageIndex records' places: the cuts among them are the ones that lost data
    with path.open("rb") as handle:
        reader = StreamReader(handle, emit_chunks=True)
        spots = []
        for record in reader.records:
            if isinstance(record, MessageIndex):
                spots.append(handle.tell())
    assert len(spots) >= 10
    cuts = sorted({*spots[:: max(len(spots) // 12, 1)], *(x - 7 for x in spots[1::7])})
    cuts.append(len(whole) - 400)  # no summary or footer
    for cut in cuts:
        part = tmp_path / f"cut{cut}.mcap"
        part.write_bytes(whole[:cut])
        expected: dict[int, int] = {}
        with part.open("rb") as handle:
            try:
                for record in StreamReader(handle).records:
                    if isinstance(record, McapMessage):
                        expected[record.channel_id] = expected.get(record.channel_id, 0) + 1
            except Exception:  # noqa: BLE001 - the reference stops at the damage
                pass
        mine = open_input(part)
        got = collect(mine.chunks())
        counts = sorted(got[names[c]][0].size for c in data if names[c] in got)
        assert counts == sorted(expected.values()), (cut, counts, expected)
        assert mine.info.errors, cut  # a cut file is never said to be whole


def test_mcap_cut_inside_magic(tmp_path: Path) -> None:
    path = tmp_path / "tiny.mcap"
    path.write_bytes(b"\x89MCA")
    with pytest.raises(ReaderError, match="truncated MCAP file"):
        open_input(path)


def test_truncated_ros1_bag_reads_complete_chunks(tmp_path: Path) -> None:
    t, data = synthetic(40_000, channels=2)
    path = tmp_path / "full.bag"
    names = write_archive(path, "ros1bag", t, data)
    cut = tmp_path / "cut.bag"
    cut.write_bytes(path.read_bytes()[: path.stat().st_size * 7 // 10])
    reader = open_input(cut)
    got = collect(reader.chunks())
    assert any("read sequentially" in e for e in reader.info.errors), reader.info.errors
    assert any("truncated or damaged" in e for e in reader.info.errors), reader.info.errors
    t_got, v_got = got[names["s0"]]
    assert 0 < t_got.size < t.size
    np.testing.assert_array_equal(v_got, data["s0"][: t_got.size])


def test_unindexed_ros1_bag_is_scanned(tmp_path: Path) -> None:
    t, data = synthetic(3000, channels=2)
    path = tmp_path / "bag.bag"
    names = write_archive(path, "ros1bag", t, data)
    raw = bytearray(path.read_bytes())
    at = raw.index(b"index_pos=") + len(b"index_pos=")
    raw[at : at + 8] = struct.pack("<Q", 0)  # as left by a killed recorder
    path.write_bytes(bytes(raw))
    reader = open_input(path)
    got = collect(reader.chunks())
    assert any("not indexed" in e for e in reader.info.errors)
    np.testing.assert_array_equal(got[names["s1"]][1], data["s1"])


def _custom_type_bag(path: Path) -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg("float64 value\nstring label\n", "my_pkg/msg/Reading"))
    cls = store.types["my_pkg/msg/Reading"]
    with Bag2Writer(path, version=9) as writer:
        conn = writer.add_connection("/reading", "my_pkg/msg/Reading", typestore=store)
        for i in range(5):
            writer.write(
                conn,
                1_000 + i,
                store.serialize_cdr(cls(value=float(i), label="a"), "my_pkg/msg/Reading"),
            )


def _msg_file(root: Path, msgtype: str, text: str) -> None:
    """``root/<package>/msg/<Type>.msg`` holding ``text``: a message path's definition."""
    path = root / f"{msgtype}.msg"
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)


def _strip_definitions(bag: Path) -> None:
    for db in bag.glob("*.db3"):
        with sqlite3.connect(db) as conn:
            conn.execute("DELETE FROM message_definitions")


def test_custom_type_with_definitions_reads(tmp_path: Path) -> None:
    bag = tmp_path / "custom"
    _custom_type_bag(bag)
    got = collect(open_input(bag).chunks())
    np.testing.assert_array_equal(got["/reading.value"][1], np.arange(5.0))
    assert "/reading.label" not in got


def test_unknown_type_without_definitions(tmp_path: Path) -> None:
    bag = tmp_path / "custom"
    _custom_type_bag(bag)
    _strip_definitions(bag)
    with pytest.raises(
        ReaderError,
        match=r"unknown message type 'my_pkg/msg/Reading' "
        "without definitions",
    ) as err:
        open_input(bag)
    one_line(err, bag)


def test_a_message_path_defines_what_the_bag_does_not(tmp_path: Path, monkeypatch) -> None:
    """``--msg-path`` (``ANALYZER_MSG_PATH``): the ``.msg`` files of the user's packages
    define the types a bag without definitions uses; the bag then reads as if it
    embedded them."""
    from analyzer.types import MSG_PATH_ENV

    bag = tmp_path / "custom"
    _custom_type_bag(bag)
    _strip_definitions(bag)
    with pytest.raises(ReaderError, match=r"give the folder .* with --msg-path"):
        open_input(bag)
    _msg_file(tmp_path / "msgs", "my_pkg/msg/Reading", "float64 value\nstring label\n")
    (tmp_path / "msgs" / "my_pkg" / "README.msg").write_text("not in a msg/ folder: ignored")
    monkeypatch.setenv(
        MSG_PATH_ENV, str(tmp_path / "nowhere") + os.pathsep + str(tmp_path / "msgs")
    )
    with pytest.raises(ReaderError, match="nowhere: no such directory"):
        open_input(bag)
    # a workspace of another distribution may define a standard type differently: its
    # definition is the one kept, not an error
    _msg_file(tmp_path / "msgs", "std_msgs/msg/String", "string data\nint32 revision\n")
    monkeypatch.setenv(MSG_PATH_ENV, str(tmp_path / "msgs"))
    got = collect(open_input(bag).chunks())
    np.testing.assert_array_equal(got["/reading.value"][1], np.arange(5.0))
    from analyzer.readers.rostypes import user_store

    store = user_store(str(tmp_path / "msgs"))
    assert store is not None and len(store.fielddefs["std_msgs/msg/String"][1]) == 2


def _custom_type_mcap(path: Path) -> None:
    """An MCAP file whose schema names a custom type but carries no definition (empty
    ``ros2msg`` data, as some recorders write it)."""
    from mcap.writer import Writer as McapWriter

    store = get_typestore(Stores.ROS2_HUMBLE)
    store.register(get_types_from_msg("float64 value\nstring label\n", "my_pkg/msg/Reading"))
    cls = store.types["my_pkg/msg/Reading"]
    with path.open("wb") as f:
        writer = McapWriter(f)
        writer.start(profile="ros2")
        schema = writer.register_schema("my_pkg/msg/Reading", "ros2msg", b"")
        channel = writer.register_channel("/reading", "cdr", schema)
        for i in range(5):
            data = store.serialize_cdr(cls(value=float(i), label="a"), "my_pkg/msg/Reading")
            writer.add_message(channel, 1_000 + i, bytes(data), 1_000 + i)
        writer.finish()


def test_an_mcap_schema_without_definition_reads_with_a_message_path(
    tmp_path: Path, monkeypatch
) -> None:
    """An MCAP schema that names a custom type but holds no definition: the channel is
    reported and skipped, naming --msg-path (not taken for a type without fields: its
    messages are longer than an empty one's); with the package's ``.msg`` files on the
    message path it reads."""
    from analyzer.types import MSG_PATH_ENV

    path = tmp_path / "custom.mcap"
    _custom_type_mcap(path)
    monkeypatch.delenv(MSG_PATH_ENV, raising=False)
    reader = open_input(path)
    assert collect(reader.chunks()) == {}
    assert reader.info.errors == [
        "/reading: message type 'my_pkg/msg/Reading' has an empty definition in the file but "
        "18-byte messages: unknown without definitions (give the folder that holds "
        "my_pkg/msg/Reading.msg with --msg-path); skipped"
    ]
    _msg_file(tmp_path / "msgs", "my_pkg/msg/Reading", "float64 value\nstring label\n")
    monkeypatch.setenv(MSG_PATH_ENV, str(tmp_path / "msgs"))
    got = collect(open_input(path).chunks())
    np.testing.assert_array_equal(got["/reading.value"][1], np.arange(5.0))
    assert "/reading.label" not in got


def test_standard_type_without_definitions_falls_back(tmp_path: Path) -> None:
    t, data = synthetic(500, channels=3)
    bag = tmp_path / "imu"
    names = write_ros2_bag(bag, t, data, layout="imu")
    _strip_definitions(bag)
    got = collect(open_input(bag).chunks())
    for key, name in names.items():
        np.testing.assert_array_equal(got[name][1], data[key])


def test_unsupported_serialization_format(tmp_path: Path) -> None:
    t, data = synthetic(50, channels=1)
    bag = tmp_path / "bag"
    write_ros2_bag(bag, t, data)
    meta = bag / "metadata.yaml"
    meta.write_text(
        meta.read_text().replace("serialization_format: cdr", "serialization_format: json")
    )
    with pytest.raises(ReaderError, match="unsupported serialization_format 'json'") as err:
        open_input(bag)
    one_line(err, bag)


def test_csv_without_numeric_column(tmp_path: Path) -> None:
    """A readable CSV whose columns are all text opens (``inspect`` lists it, with a
    note: ``tests/cli/test_nothing_numeric.py``) and yields nothing, saying why; in a
    folder it is a member not read, with that reason, as when it was refused on opening."""
    path = tmp_path / "labels.csv"
    path.write_text("time,label\n0.0,a\n0.1,b\n")
    reader = open_input(path)
    assert reader.info.no_numeric == (
        "no numeric column besides the time column 'time' (text: label)"
    )
    assert list(reader.chunks()) == []
    (tmp_path / "data.csv").write_text("time,x\n0.0,1\n0.1,2\n")
    archive = open_archive(tmp_path)
    assert [i.path.name for i in archive.inputs] == ["data.csv", "labels.csv"]
    assert archive.inputs[1].errors == [reader.info.no_numeric]
    assert {c.name for c in archive.chunks()} == {"x"}


def test_csv_with_unparseable_time(tmp_path: Path) -> None:
    path = tmp_path / "odd.csv"
    path.write_text("time,x\nabc,1\ndef,2\n")
    with pytest.raises(ReaderError, match="holds neither numbers nor dates"):
        open_input(path)


def test_directory_is_not_a_single_input(tmp_path: Path) -> None:
    with pytest.raises(ReaderError, match="not a ROS 2 bag"):
        open_input(tmp_path)
    with pytest.raises(ReaderError, match="holds no input"):
        open_archive(tmp_path)


def test_detect_format_prefers_magic(tmp_path: Path) -> None:
    t, data = synthetic(50, channels=1)
    path = tmp_path / "actually_mcap.bag"
    write_archive(path, "mcap", t, data)
    assert detect_format(path) is Format.MCAP
    assert open_input(path).info.format is Format.MCAP


@pytest.mark.parametrize("fmt", ["mcap", "ros1bag", "csv"])
def test_random_damage_reads_or_raises_cleanly(tmp_path: Path, fmt: str) -> None:
    """Flipped bytes, zeroed runs and cut-out runs anywhere: the reader either reads
    (recording what it skipped) or raises a one-line ReaderError, never anything else."""
    t, data = synthetic(1500, channels=3)
    suffix = {"mcap": ".mcap", "ros1bag": ".bag", "csv": ".csv"}[fmt]
    good = tmp_path / f"good{suffix}"
    write_archive(good, fmt, t, data, layout="imu")
    original = good.read_bytes()
    rng = np.random.default_rng(11)
    for trial in range(15):
        raw = bytearray(original)
        at = int(rng.integers(0, len(raw)))
        if trial % 3 == 0:
            for i in rng.integers(0, len(raw), size=8):
                raw[int(i)] = int(rng.integers(0, 256))
        elif trial % 3 == 1:
            raw[at : at + 3000] = bytes(len(raw[at : at + 3000]))
        else:
            del raw[at : at + int(rng.integers(1, 300))]
        path = tmp_path / f"damaged{trial}{suffix}"
        path.write_bytes(bytes(raw))
        try:
            archive = open_archive(path)
        except ReaderError as err:
            assert "\n" not in str(err)
            continue
        collect(archive.chunks())
        collect(archive.chunks("header"))


def test_an_empty_message_type_is_no_channel_and_no_error(tmp_path):
    """A topic whose message definition is empty (a marker type, ``test_msgs/Empty`` in
    rosbag2's test bags) has no field: no channel, and nothing wrong with the file."""
    import struct

    from mcap.writer import Writer

    from analyzer.inspect import inspect_archive

    path = tmp_path / "marker.mcap"
    with path.open("wb") as f:
        w = Writer(f)
        w.start()
        empty = w.register_schema("my_msgs/msg/Marker", "ros2msg", b"")
        value = w.register_schema("my_msgs/msg/Value", "ros2msg", b"float64 data\n")
        c1 = w.register_channel("/marker", "cdr", empty)
        c2 = w.register_channel("/value", "cdr", value)
        for k in range(50):
            t = k * 10_000_000
            w.add_message(c1, log_time=t, data=b"\x00\x01\x00\x00\x00", publish_time=t)
            payload = b"\x00\x01\x00\x00" + struct.pack("<d", float(k))
            w.add_message(c2, log_time=t, data=payload, publish_time=t)
        w.finish()
    doc = inspect_archive([str(path)])
    assert doc["inputs"][0]["errors"] == []
    assert [c["name"] for c in doc["channels"]] == ["/value.data"]


def test_a_fifo_is_refused_or_skipped_never_opened(tmp_path: Path) -> None:
    """Opening a FIFO waits for a writer, forever: ``analyzer inspect x.csv`` and a run
    on a folder holding one hung. Given, it is refused by name; in a folder, skipped
    with a note, the rest read."""
    fifo = tmp_path / "pipe.csv"
    os.mkfifo(fifo)
    with pytest.raises(ReaderError, match=r"pipe\.csv: not a regular file \(a FIFO\)"):
        open_input(fifo)
    folder = tmp_path / "archive"
    folder.mkdir()
    os.mkfifo(folder / "pipe.csv")
    t_ns = np.arange(50, dtype=np.int64) * 10_000_000
    write_archive(folder / "a.csv", "csv", t_ns, {"x": np.arange(50.0), "y": -np.arange(50.0)})
    archive = open_archive(folder)
    assert [i.path.name for i in archive.inputs] == ["a.csv"]
    assert archive.notes == [f"{folder / 'pipe.csv'} not read: not a regular file (a FIFO)"]


def test_relative_and_unix_times_are_not_one_archive(tmp_path: Path) -> None:
    """A CSV of seconds from its start beside an MCAP of Unix times failed with "a
    timestamp lies far from the others (an outlier, or a wrong unit)"."""
    t_ns = np.arange(100, dtype=np.int64) * 10_000_000
    data = {"x": np.arange(100.0), "y": -np.arange(100.0)}
    write_archive(tmp_path / "rel.csv", "csv", t_ns, data)
    write_archive(tmp_path / "abs.mcap", "mcap", t_ns, data, start_iso="2026-01-01T00:00:00Z")
    with pytest.raises(ReaderError, match=r"rel\.csv has relative times .*abs\.mcap Unix"):
        open_archive([tmp_path / "rel.csv", tmp_path / "abs.mcap"])
    # (other values: the same bytes as rel.csv, relative times from 0, are read once)
    later = {k: v + 1.0 for k, v in data.items()}
    write_archive(tmp_path / "rel2.csv", "csv", t_ns + 2_000_000_000, later)
    archive = open_archive([tmp_path / "rel.csv", tmp_path / "rel2.csv"])  # one clock: fine
    assert len(archive.inputs) == 2

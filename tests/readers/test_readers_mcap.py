"""MCAP reader: every encoding, chunked or not, indexed or not, against what was written
and against the reference decoders of the mcap ecosystem."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, IndexType
from mcap.writer import Writer as McapWriter
from mcap_ros2.decoder import DecoderFactory
from readers_helpers import collect, synthetic
from rosbags.typesys import Stores, get_typestore

from analyzer.readers import open_input
from analyzer.readers._common import concat_payloads
from analyzer.readers.decoders import JsonBatchDecoder
from analyzer.readers.mcap_reader import McapReader
from analyzer.writers import bulk_serialize, default_message, write_archive


@pytest.mark.parametrize("layout", ["float64", "multiarray", "imu"])
@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_round_trip(tmp_path: Path, layout: str, compression: str) -> None:
    t, data = synthetic(4000, channels=4)
    path = tmp_path / "a.mcap"
    names = write_archive(
        path, "mcap", t, data, layout=layout, compression=compression, chunk_size=16 * 1024
    )
    reader = open_input(path)
    got = collect(reader.chunks())
    assert reader.info.errors == []
    for key, name in names.items():
        np.testing.assert_array_equal(got[name][0], t)
        np.testing.assert_array_equal(got[name][1], data[key])
    assert reader.start_ns() == t[0]
    if layout == "multiarray":
        np.testing.assert_array_equal(got["/data.layout.data_offset"][1], 0.0)
    if layout == "imu":
        np.testing.assert_array_equal(got["/imu1.orientation.w"][1], 1.0)
        assert len([n for n in got if n.startswith("/imu0.")]) == 37
        assert not any(".header." in n for n in got)


def test_values_equal_the_mcap_ros2_reference_decoder(tmp_path: Path) -> None:
    """Written message by message by mcap_ros2's own encoder, decoded by its decoder."""
    t, data = synthetic(300, channels=3)
    path = tmp_path / "lib.mcap"
    names = write_archive(path, "mcap", t, data, layout="imu", serializer="library")
    reference: dict[str, list[float]] = {}
    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, channel, _, msg in reader.iter_decoded_messages():
            for axis in "xyz":
                name = f"{channel.topic}.linear_acceleration.{axis}"
                reference.setdefault(name, []).append(getattr(msg.linear_acceleration, axis))
            reference.setdefault(f"{channel.topic}.orientation_covariance[4]", []).append(
                msg.orientation_covariance[4]
            )
    got = collect(open_input(path).chunks())
    for name, values in reference.items():
        np.testing.assert_array_equal(got[name][1], np.asarray(values))
    for key, name in names.items():
        np.testing.assert_array_equal(got[name][1], data[key])


def _raw_mcap(
    path: Path,
    messages: list[tuple[str, int, bytes]],
    *,
    schema: tuple[str, str, str],
    encoding: str,
    **writer_args: object,
) -> None:
    with path.open("wb") as handle:
        writer = McapWriter(handle, **writer_args)  # type: ignore[arg-type]
        writer.start(profile="", library="test")
        name, schema_encoding, text = schema
        schema_id = writer.register_schema(name, schema_encoding, text.encode())
        channels: dict[str, int] = {}
        for topic, stamp, payload in messages:
            if topic not in channels:
                channels[topic] = writer.register_channel(topic, encoding, schema_id)
            writer.add_message(channels[topic], stamp, payload, stamp)
        writer.finish()


def _float64_messages(t: np.ndarray, values: np.ndarray, encoding: str) -> list[bytes]:
    store = get_typestore(Stores.ROS2_HUMBLE if encoding == "cdr" else Stores.ROS1_NOETIC)
    template = default_message(store, "std_msgs/msg/Float64")
    rows = bulk_serialize(
        store, "std_msgs/msg/Float64", template, {"data": values}, encoding=encoding
    )
    return [row.tobytes() for row in rows]


@pytest.mark.parametrize(
    "writer_args",
    [
        {"use_chunking": False},
        {
            "index_types": IndexType.NONE,
            "repeat_channels": False,
            "repeat_schemas": False,
            "use_statistics": False,
            "use_summary_offsets": False,
            "chunk_size": 2048,
        },
        {"compression": CompressionType.LZ4, "chunk_size": 1024, "index_types": IndexType.CHUNK},
    ],
    ids=["unchunked", "no-summary", "no-message-index"],
)
def test_unindexed_variants(tmp_path: Path, writer_args: dict[str, object]) -> None:
    t, data = synthetic(1500, channels=1)
    store = get_typestore(Stores.ROS2_HUMBLE)
    text, _ = store.generate_msgdef("std_msgs/msg/Float64", ros_version=2)
    payloads = _float64_messages(t, data["s0"], "cdr")
    path = tmp_path / "v.mcap"
    _raw_mcap(
        path,
        [("/s0", int(s), p) for s, p in zip(t, payloads, strict=True)],
        schema=("std_msgs/msg/Float64", "ros2msg", text),
        encoding="cdr",
        **writer_args,
    )
    reader = open_input(path)
    got = collect(reader.chunks())
    assert reader.info.errors == []
    np.testing.assert_array_equal(got["/s0.data"][0], t)
    np.testing.assert_array_equal(got["/s0.data"][1], data["s0"])
    assert reader.start_ns() == t[0]


def test_ros1msg_encoding(tmp_path: Path) -> None:
    t, data = synthetic(800, channels=1)
    store = get_typestore(Stores.ROS1_NOETIC)
    text, _ = store.generate_msgdef("std_msgs/msg/Float64")
    path = tmp_path / "ros1.mcap"
    payloads = _float64_messages(t, data["s0"], "ros1")
    _raw_mcap(
        path,
        [("/s0", int(s), p) for s, p in zip(t, payloads, strict=True)],
        schema=("std_msgs/Float64", "ros1msg", text),
        encoding="ros1",
    )
    got = collect(open_input(path).chunks())
    np.testing.assert_array_equal(got["/s0.data"][1], data["s0"])


def test_out_of_order_messages_are_sorted(tmp_path: Path) -> None:
    """Chunks overlapping in time (a writer that logged late): output still in order."""
    t, data = synthetic(6000, channels=1)
    store = get_typestore(Stores.ROS2_HUMBLE)
    text, _ = store.generate_msgdef("std_msgs/msg/Float64", ros_version=2)
    payloads = _float64_messages(t, data["s0"], "cdr")
    order = np.concatenate([np.arange(3000, 6000), np.arange(0, 3000)])
    order[100:200] = order[100:200][::-1]
    path = tmp_path / "shuffled.mcap"
    _raw_mcap(
        path,
        [("/s0", int(t[i]), payloads[i]) for i in order],
        schema=("std_msgs/msg/Float64", "ros2msg", text),
        encoding="cdr",
        chunk_size=4096,
    )
    got = collect(open_input(path).chunks())
    np.testing.assert_array_equal(got["/s0.data"][0], t)
    np.testing.assert_array_equal(got["/s0.data"][1], data["s0"])


def _json_payloads(n: int) -> tuple[list[bytes], dict[str, list[tuple[int, float]]]]:
    rng = np.random.default_rng(3)
    payloads = []
    expected: dict[str, list[tuple[int, float]]] = {}
    for i in range(n):
        msg = {
            "header": {"stamp": {"sec": 100 + i, "nanosec": 5}, "frame_id": "f"},
            "pos": {"x": float(rng.normal()), "y": int(i)},
            "ok": bool(i % 2),
            "name": "text",
            "samples": [float(i)] * (1 + i % 3),
            "maybe": None if i % 4 == 0 else 1.5,
        }
        payloads.append(json.dumps(msg, indent=1 if i % 5 == 0 else None).encode())
        for name, value in (("pos.x", msg["pos"]["x"]), ("pos.y", float(i)), ("ok", float(i % 2))):
            expected.setdefault(name, []).append((i, value))
        for j in range(1 + i % 3):
            expected.setdefault(f"samples[{j}]", []).append((i, float(i)))
        if i % 4:
            expected.setdefault("maybe", []).append((i, 1.5))
    return payloads, expected


@pytest.mark.parametrize("bulk", [True, False], ids=["arrow", "json.loads"])
def test_json_decoder(bulk: bool) -> None:
    payloads, expected = _json_payloads(60)
    buf, starts, sizes = concat_payloads(payloads)
    decoded = JsonBatchDecoder(bulk=bulk).decode(buf, starts, sizes)
    assert set(decoded.columns) == set(expected)
    for name, pairs in expected.items():
        rows, values = decoded.columns[name]
        want_rows = np.asarray([r for r, _ in pairs])
        if rows is None:
            rows = np.arange(60)
        np.testing.assert_array_equal(rows, want_rows)
        np.testing.assert_array_equal(values, [v for _, v in pairs])
    assert decoded.stamps is not None
    np.testing.assert_array_equal(decoded.stamps, (100 + np.arange(60)) * 1_000_000_000 + 5)


def test_json_type_change_falls_back() -> None:
    payloads = [b'{"a": 1}', b'{"a": "one"}', b'{"a": 2.5}']
    buf, starts, sizes = concat_payloads(payloads)
    decoded = JsonBatchDecoder().decode(buf, starts, sizes)
    rows, values = decoded.columns["a"]
    np.testing.assert_array_equal(rows, [0, 2])
    np.testing.assert_array_equal(values, [1.0, 2.5])


def test_json_mcap_and_unsupported_encoding(tmp_path: Path) -> None:
    path = tmp_path / "mixed.mcap"
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start()
        schema = writer.register_schema("Pos", "jsonschema", b"{}")
        good = writer.register_channel("/pos", "json", schema)
        custom = writer.register_schema("blob", "x-custom", b"...")
        bad = writer.register_channel("/blob", "x-custom", custom)
        for i in range(50):
            writer.add_message(good, 1000 + i, json.dumps({"x": i / 2}).encode(), 1000 + i)
            writer.add_message(bad, 1000 + i, b"\x01\x02", 1000 + i)
        writer.finish()
    reader = open_input(path)
    got = collect(reader.chunks())
    np.testing.assert_array_equal(got["/pos.x"][1], np.arange(50) / 2)
    assert reader.info.errors == ["/blob: unsupported message encoding 'x-custom'; skipped"]


def test_header_time(tmp_path: Path) -> None:
    t, data = synthetic(1000, channels=3)
    path = tmp_path / "imu.mcap"
    names = write_archive(path, "mcap", t, data, layout="imu", header_offset_ns=3_000_000)
    reader = open_input(path)
    by_log = collect(reader.chunks("log"))
    by_header = collect(reader.chunks("header"))
    name = names["s1"]
    np.testing.assert_array_equal(by_log[name][0], t)
    np.testing.assert_array_equal(by_header[name][0], t + 3_000_000)
    np.testing.assert_array_equal(by_header[name][1], data["s1"])


def test_bulk_and_reference_paths_agree_on_a_file(tmp_path: Path) -> None:
    t, data = synthetic(700, channels=5)
    path = tmp_path / "imu.mcap"
    write_archive(path, "mcap", t, data, layout="imu")
    fast = collect(McapReader(path).chunks())
    slow = collect(McapReader(path, bulk=False).chunks())
    assert fast.keys() == slow.keys()
    for name in fast:
        np.testing.assert_array_equal(fast[name][0], slow[name][0])
        np.testing.assert_array_equal(fast[name][1], slow[name][1])

"""ROS 1 and ROS 2 bag readers on bags written by rosbags, and the bulk serializer of
:mod:`analyzer.writers` against the libraries' own per-message serializers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from readers_helpers import collect, synthetic
from rosbags.highlevel import AnyReader
from rosbags.typesys import Stores, get_typestore

from analyzer.readers import open_input
from analyzer.readers.ros1_reader import Ros1BagReader
from analyzer.readers.ros2_reader import Ros2BagReader
from analyzer.writers import bulk_serialize, default_message, write_archive, write_ros2_bag


@pytest.mark.parametrize("compression", [None, "bz2", "lz4"])
def test_ros1_compressions(tmp_path: Path, compression: str | None) -> None:
    t, data = synthetic(3000, channels=4)
    path = tmp_path / "x.bag"
    names = write_archive(path, "ros1bag", t, data, layout="imu", compression=compression)
    bag = open_input(path)
    got = collect(bag.chunks())
    assert bag.info.errors == []
    for key, name in names.items():
        np.testing.assert_array_equal(got[name][0], t)
        np.testing.assert_array_equal(got[name][1], data[key])


@pytest.mark.parametrize("layout", ["float64", "multiarray", "imu"])
def test_ros1_bulk_equals_reference_reader(tmp_path: Path, layout: str) -> None:
    t, data = synthetic(800, channels=4)
    path = tmp_path / "x.bag"
    write_archive(path, "ros1bag", t, data, layout=layout)
    fast = collect(Ros1BagReader(path).chunks("header"))
    slow = collect(Ros1BagReader(path, bulk=False).chunks("header"))
    assert fast.keys() == slow.keys()
    for name in fast:
        np.testing.assert_array_equal(fast[name][0], slow[name][0])
        np.testing.assert_array_equal(fast[name][1], slow[name][1])


@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_ros2_storages_and_header_time(tmp_path: Path, storage: str) -> None:
    t, data = synthetic(1500, channels=5)
    path = tmp_path / "bag"
    names = write_ros2_bag(path, t, data, layout="imu", storage=storage, header_offset_ns=-7_000)
    bag = Ros2BagReader(path)
    assert bag.start_ns() == t[0]
    by_log = collect(bag.chunks())
    by_header = collect(bag.chunks("header"))
    for key, name in names.items():
        np.testing.assert_array_equal(by_log[name][0], t)
        np.testing.assert_array_equal(by_header[name][0], t - 7_000)
        np.testing.assert_array_equal(by_header[name][1], data[key])
    assert bag.info.errors == []


def test_ros2_bare_db3_file(tmp_path: Path) -> None:
    t, data = synthetic(300, channels=2)
    path = tmp_path / "bag"
    names = write_ros2_bag(path, t, data)
    db3 = next(path.glob("*.db3"))
    bag = open_input(db3)
    got = collect(bag.chunks())
    np.testing.assert_array_equal(got[names["s1"]][1], data["s1"])


def test_ros2_values_equal_rosbags_reference(tmp_path: Path) -> None:
    t, data = synthetic(400, channels=3)
    path = tmp_path / "bag"
    write_ros2_bag(path, t, data, layout="multiarray")
    with AnyReader([path]) as reader:
        reference = np.asarray(
            [reader.deserialize(raw, c.msgtype).data for c, _, raw in reader.messages()]
        )
    got = collect(open_input(path).chunks())
    for i in range(3):
        np.testing.assert_array_equal(got[f"/data.data[{i}]"][1], reference[:, i])


@pytest.mark.parametrize("encoding", ["cdr", "ros1"])
def test_bulk_serializer_matches_rosbags(encoding: str) -> None:
    store = get_typestore(Stores.ROS2_HUMBLE if encoding == "cdr" else Stores.ROS1_NOETIC)
    msgtype = "sensor_msgs/msg/Imu"
    header = default_message(store, "std_msgs/msg/Header", frame_id="imu7")
    template = default_message(store, msgtype, header=header)
    values = np.linspace(-1.0, 1.0, 20)
    stamps = np.arange(20, dtype=np.int64) * 1_500_000_017 + 3
    rows = bulk_serialize(
        store,
        msgtype,
        template,
        {"angular_velocity.y": values, "orientation_covariance[3]": -values},
        encoding=encoding,
        stamps=stamps,
    )
    for i in range(20):
        template.angular_velocity.y = values[i]
        template.orientation_covariance[3] = -values[i]
        template.header.stamp.sec = int(stamps[i] // 1_000_000_000)
        template.header.stamp.nanosec = int(stamps[i] % 1_000_000_000)
        serialize = store.serialize_cdr if encoding == "cdr" else store.serialize_ros1
        assert rows[i].tobytes() == bytes(serialize(template, msgtype))


def test_bulk_mcap_matches_mcap_ros2_encoder(tmp_path: Path) -> None:
    t, data = synthetic(200, channels=3)
    payloads = {}
    for serializer in ("numpy", "library"):
        path = tmp_path / f"{serializer}.mcap"
        write_archive(path, "mcap", t, data, layout="imu", serializer=serializer)
        with path.open("rb") as handle:
            payloads[serializer] = [
                (channel.topic, message.log_time, message.data)
                for _, channel, message in make_reader(handle).iter_messages()
            ]
    assert payloads["numpy"] == payloads["library"]

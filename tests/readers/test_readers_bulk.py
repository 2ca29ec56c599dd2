"""The fixed-layout bulk decoder gives exactly what the reference decoder (rosbags'
deserializer, flattened) gives, message by message."""

from __future__ import annotations

import numpy as np
import pytest
from rosbags.typesys import Stores, get_typestore
from rosbags.typesys.store import Typestore

from analyzer.readers._common import concat_payloads
from analyzer.readers.rosdecode import RosBatchDecoder, compute_layout
from analyzer.writers import default_message

RNG = np.random.default_rng(7)


def _store(encoding: str) -> Typestore:
    return get_typestore(Stores.ROS2_HUMBLE if encoding == "cdr" else Stores.ROS1_NOETIC)


def _serialize(
    store: Typestore, msgtype: str, msg: object, encoding: str, little: bool = True
) -> bytes:
    if encoding == "cdr":
        return bytes(store.serialize_cdr(msg, msgtype, little_endian=little))
    return bytes(store.serialize_ros1(msg, msgtype))


def _imu(store: Typestore, i: int) -> object:
    vec = store.types["geometry_msgs/msg/Vector3"]
    quat = store.types["geometry_msgs/msg/Quaternion"]
    header = default_message(store, "std_msgs/msg/Header", frame_id="imu_link")
    header.stamp.sec, header.stamp.nanosec = 1_700_000_000 + i, 1000 * i
    return default_message(
        store,
        "sensor_msgs/msg/Imu",
        header=header,
        orientation=quat(*RNG.normal(size=4)),
        orientation_covariance=RNG.normal(size=9),
        angular_velocity=vec(*RNG.normal(size=3)),
        linear_acceleration=vec(*RNG.normal(size=3)),
        linear_acceleration_covariance=RNG.normal(size=9),
    )


def _multiarray(store: Typestore, i: int, size: int = 16) -> object:
    dim = default_message(
        store, "std_msgs/msg/MultiArrayDimension", label="x", size=size, stride=size
    )
    layout = default_message(store, "std_msgs/msg/MultiArrayLayout", dim=[dim], data_offset=i % 3)
    return default_message(
        store, "std_msgs/msg/Float64MultiArray", layout=layout, data=RNG.normal(size=size)
    )


def _joints(store: Typestore, i: int, joints: int = 6, prefix: str = "joint_") -> object:
    header = default_message(store, "std_msgs/msg/Header", frame_id="base")
    return default_message(
        store,
        "sensor_msgs/msg/JointState",
        header=header,
        name=[f"{prefix}{j}" for j in range(joints)],
        position=RNG.normal(size=joints),
        velocity=RNG.normal(size=joints),
        effort=np.zeros(0) if i % 5 == 0 else RNG.normal(size=joints),
    )


def _compare(
    store: Typestore,
    msgtype: str,
    payloads: list[bytes],
    encoding: str,
    expect_layouts: int | None = None,
) -> None:
    buf, starts, sizes = concat_payloads(payloads)
    bulk = RosBatchDecoder([store], msgtype, encoding)
    fast = bulk.decode(buf, starts, sizes)
    slow = RosBatchDecoder([store], msgtype, encoding, bulk=False).decode(buf, starts, sizes)
    assert fast.failed == slow.failed == 0
    assert fast.columns.keys() == slow.columns.keys()
    for name in fast.columns:
        rows_fast, values_fast = fast.columns[name]
        rows_slow, values_slow = slow.columns[name]
        if rows_fast is None or rows_slow is None:
            assert rows_fast is None and rows_slow is None, name
        else:
            np.testing.assert_array_equal(rows_fast, rows_slow, err_msg=name)
        np.testing.assert_array_equal(values_fast, values_slow, err_msg=name)
    if slow.stamps is None:
        assert fast.stamps is None
    else:
        np.testing.assert_array_equal(fast.stamps, slow.stamps)
    if expect_layouts is not None:
        assert len(bulk._layouts) == expect_layouts


@pytest.mark.parametrize("encoding", ["cdr", "ros1"])
def test_imu(encoding: str) -> None:
    store = _store(encoding)
    msgs = [_serialize(store, "sensor_msgs/msg/Imu", _imu(store, i), encoding) for i in range(300)]
    _compare(store, "sensor_msgs/msg/Imu", msgs, encoding, expect_layouts=1)


def test_imu_big_endian_cdr() -> None:
    store = _store("cdr")
    msgs = [
        _serialize(store, "sensor_msgs/msg/Imu", _imu(store, i), "cdr", little=False)
        for i in range(50)
    ]
    _compare(store, "sensor_msgs/msg/Imu", msgs, "cdr", expect_layouts=1)


@pytest.mark.parametrize("encoding", ["cdr", "ros1"])
def test_float64_multiarray(encoding: str) -> None:
    store = _store(encoding)
    msgtype = "std_msgs/msg/Float64MultiArray"
    msgs = [_serialize(store, msgtype, _multiarray(store, i), encoding) for i in range(200)]
    _compare(store, msgtype, msgs, encoding, expect_layouts=1)


@pytest.mark.parametrize("encoding", ["cdr", "ros1"])
def test_joint_state_constant_and_varying(encoding: str) -> None:
    store = _store(encoding)
    msgtype = "sensor_msgs/msg/JointState"
    constant = [
        _serialize(store, msgtype, _joints(store, i), encoding) for i in range(1, 200) if i % 5
    ]
    _compare(store, msgtype, constant, encoding, expect_layouts=1)
    # joint count, empty effort and name lengths change: several layouts, same values
    varying = [
        _serialize(
            store,
            msgtype,
            _joints(store, i, joints=3 + i % 4, prefix="j" if i % 7 == 0 else "joint_"),
            encoding,
        )
        for i in range(300)
    ]
    _compare(store, msgtype, varying, encoding)


def test_same_size_different_prefixes_are_told_apart() -> None:
    """Two JointStates of the same byte size whose string lengths differ: the size check
    alone would mix them up; the length-prefix check must not."""
    store = _store("ros1")
    msgtype = "sensor_msgs/msg/JointState"
    a = default_message(
        store,
        msgtype,
        name=["abcd"],
        position=np.array([1.0]),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    b = default_message(
        store,
        msgtype,
        name=[],
        position=np.array([2.0, 3.0]),
        velocity=np.zeros(0),
        effort=np.zeros(0),
    )
    raw_a, raw_b = (_serialize(store, msgtype, m, "ros1") for m in (a, b))
    assert len(raw_a) == len(raw_b)
    _compare(store, msgtype, [raw_a, raw_b, raw_a], "ros1", expect_layouts=2)
    buf, starts, sizes = concat_payloads([raw_a, raw_b, raw_a])
    decoded = RosBatchDecoder([store], msgtype, "ros1").decode(buf, starts, sizes)
    np.testing.assert_array_equal(decoded.columns["position[0]"][1], [1.0, 2.0, 1.0])
    rows, values = decoded.columns["position[1]"]
    np.testing.assert_array_equal(rows, [1])
    np.testing.assert_array_equal(values, [3.0])


def test_undecodable_messages_are_counted() -> None:
    store = _store("cdr")
    msgtype = "std_msgs/msg/Float64MultiArray"
    good = [_serialize(store, msgtype, _multiarray(store, i), "cdr") for i in range(10)]
    broken = good[:5] + [b"\x00\x01\x00\x00\xff\xff\xff\x7f"] + good[5:]
    buf, starts, sizes = concat_payloads(broken)
    decoded = RosBatchDecoder([store], msgtype, "cdr").decode(buf, starts, sizes)
    assert decoded.failed == 1 and decoded.first_error
    rows, values = decoded.columns["data[0]"]
    assert rows is not None and 5 not in rows and rows.size == 10


def test_layout_names_and_stamp_offsets() -> None:
    store = _store("cdr")
    raw = _serialize(store, "sensor_msgs/msg/Imu", _imu(store, 0), "cdr")
    layout = compute_layout(store, "sensor_msgs/msg/Imu", raw, "cdr")
    leaves = layout.leaves()
    assert len(leaves) == 37
    assert "linear_acceleration.x" in leaves and "orientation_covariance[8]" in leaves
    assert layout.stamp == (4, 8)  # right after the 4-byte encapsulation header
    offset, kind = leaves["orientation.x"]
    assert kind == "float64" and (offset - 4) % 8 == 0  # CDR alignment

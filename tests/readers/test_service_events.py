"""ROS 2 service events (``<service>/_service_event`` topics of ``pkg/srv/Name_Event``
types, recorded by rosbag2's service introspection) are the requests and responses of
service calls, not sensor data: the readers skip them with a note that says so. Before,
an MCAP (whose schema is the service's ``.srv`` text) gave ``cannot parse the msg
definition ...: syntax error; mcap_ros2: ---`` and a ROS 2 bag without definitions
asked for ``--msg-path``, as if a definition were missing (the realdata audit:
rosbag2's ``bag_with_topics_and_service_events`` and ``topics_and_services``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from readers_helpers import collect
from rosbags.rosbag2 import Writer as Bag2Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.cli import main
from analyzer.readers import open_input

SRV = "int64 a\nint64 b\n---\nint64 sum\n"
"""What a recorder stores as the definition of ``example_interfaces/srv/AddTwoInts_Event``."""

EVENT = "example_interfaces/srv/AddTwoInts_Event"


def _float64(store, value: float) -> bytes:
    cls = store.types["std_msgs/msg/Float64"]
    return bytes(store.serialize_cdr(cls(data=value), "std_msgs/msg/Float64"))


def _mcap(path: Path, with_data: bool = True) -> Path:
    store = get_typestore(Stores.ROS2_HUMBLE)
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="ros2", library="test")
        event = writer.register_schema(EVENT, "ros2msg", SRV.encode())
        calls = writer.register_channel("/add_two_ints/_service_event", "cdr", event)
        data = writer.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data\n")
        level = writer.register_channel("/level", "cdr", data)
        for i in range(20):
            stamp = 1_000_000_000 + i * 10_000_000
            # (the bytes of a call do not matter: the topic is skipped by its type)
            writer.add_message(calls, stamp, b"\x00\x01\x00\x00" + bytes(60), stamp)
            if with_data:
                writer.add_message(level, stamp, _float64(store, float(i)), stamp)
        writer.finish()
    return path


def _bag(path: Path) -> Path:
    """A ROS 2 bag (sqlite3) with a service-event topic beside a Float64 topic, the
    ``.srv`` text embedded as the event's definition (as rosbag2 stores it)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    with Bag2Writer(path, version=9) as writer:
        calls = writer.add_connection(
            "/add_two_ints/_service_event", EVENT, msgdef=SRV, rihs01="RIHS01_" + "0" * 64
        )
        level = writer.add_connection("/level", "std_msgs/msg/Float64", typestore=store)
        for i in range(20):
            stamp = 1_000_000_000 + i * 10_000_000
            # (the bytes of a call do not matter: the topic is skipped by its type)
            writer.write(calls, stamp, b"\x00\x01\x00\x00" + bytes(60))
            writer.write(level, stamp, _float64(store, float(i)))
    return path


NOTE = (
    "/add_two_ints/_service_event: ROS 2 service events (example_interfaces/srv/"
    "AddTwoInts_Event: the requests and responses of calls to a service), not sensor "
    "data; skipped"
)


@pytest.mark.parametrize("make", [_mcap, _bag], ids=["mcap", "ros2bag"])
def test_service_events_are_skipped_with_a_note(tmp_path: Path, make) -> None:
    reader = open_input(make(tmp_path / "rec"))
    got = collect(reader.chunks())
    assert list(got) == ["/level.data"]
    np.testing.assert_array_equal(got["/level.data"][1], np.arange(20.0))
    assert NOTE in reader.info.errors
    assert not any("syntax error" in e or "--msg-path" in e for e in reader.info.errors)


def test_a_file_of_service_events_only_says_so(tmp_path: Path, capsys) -> None:
    path = _mcap(tmp_path / "calls.mcap", with_data=False)
    assert main(["inspect", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert err == f"analyzer: error: no channel could be read from the input: {path}: {NOTE}"


@pytest.mark.realdata
@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_rosbag2_service_event_bag(corpus: Path, storage: str) -> None:
    bag = corpus / "ros2/rosbag2/rosbag2_tests/resources" / storage
    reader = open_input(bag / "bag_with_topics_and_service_events")
    assert collect(reader.chunks()) == {}  # (its other topics hold strings: no channel)
    text = " | ".join(reader.info.errors)
    for topic in ("/test_service1/_service_event", "/test_service2/_service_event"):
        assert f"{topic}: ROS 2 service events (test_msgs/srv/BasicTypes_Event" in text
    assert "syntax error" not in text and "--msg-path" not in text


ACTION_EVENT = "example_interfaces/action/Fibonacci_SendGoal_Event"
"""An action's goal service's event type (action introspection): a service event too."""


@pytest.mark.parametrize(
    ("msgtype", "skipped"),
    [(ACTION_EVENT, True), ("door_msgs/msg/Door_Event", False), ("door_msgs/Door_Event", False)],
)
def test_which_event_types_are_service_events(msgtype: str, skipped: bool) -> None:
    from analyzer.readers.rostypes import ServiceEventType, refuse_service_event

    if skipped:
        with pytest.raises(ServiceEventType, match=f"ROS 2 service events \\({msgtype}:"):
            refuse_service_event(msgtype)
    else:
        refuse_service_event(msgtype)  # a message type that merely ends in _Event


def test_an_action_goal_event_topic_is_skipped_with_the_note(tmp_path: Path) -> None:
    store = get_typestore(Stores.ROS2_HUMBLE)
    path = tmp_path / "goals.mcap"
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="ros2", library="test")
        goal = "int32 order\n---\nbool accepted\nbuiltin_interfaces/Time stamp\n"
        event = writer.register_schema(ACTION_EVENT, "ros2msg", goal.encode())
        calls = writer.register_channel("/fibonacci/_action/send_goal/_service_event", "cdr", event)
        data = writer.register_schema("std_msgs/msg/Float64", "ros2msg", b"float64 data\n")
        level = writer.register_channel("/level", "cdr", data)
        for i in range(20):
            stamp = 1_000_000_000 + i * 10_000_000
            writer.add_message(calls, stamp, b"\x00\x01\x00\x00" + bytes(60), stamp)
            writer.add_message(level, stamp, _float64(store, float(i)), stamp)
        writer.finish()
    reader = open_input(path)
    assert list(collect(reader.chunks())) == ["/level.data"]
    (note,) = reader.info.errors
    assert note.startswith(
        f"/fibonacci/_action/send_goal/_service_event: ROS 2 service events ({ACTION_EVENT}:"
    )

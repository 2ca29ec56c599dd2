"""MCAP files, and ROS 2 bags of MCAP storage (``storage_identifier: mcap``), whose
schema for a topic's type holds no definition, as rosbag2 (Iron on) writes it for a type
it did not find where it recorded: encoding ``unknown`` (or ``""``), no text. The plain
MCAP said ``schema encoding 'unknown' is not a ROS message definition`` (no
``--msg-path`` hint) and the bag was refused whole (``cannot open ROS 2 bag: the rosbags
library failed with KeyError 'unknown'``); now that topic is skipped with the line a
sqlite3 bag's gives (ros55a), or decoded from ``--msg-path``, and the rest is read
(rob56 #3)."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from readers_helpers import T0, collect
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.readers import open_input
from analyzer.types import MSG_PATH_ENV

ROS2 = get_typestore(Stores.ROS2_HUMBLE)
CUSTOM = "my_pkg/msg/Reading"
FLOAT = "std_msgs/msg/Float64"
N = 500
STEP = 5_000_000


def _cdr(x: float) -> bytes:
    """A ``float64 data`` message in CDR (little endian)."""
    return b"\x00\x01\x00\x00" + np.float64(x).tobytes()


def _values() -> dict[str, np.ndarray]:
    return {"/s0": np.sin(np.arange(N) / 10.0), "/s1": np.cos(np.arange(N) / 7.0)}


def _write_mcap(path: Path, encoding: str) -> None:
    """``/s0`` (``Float64``, its definition) and ``/s1`` (the custom type, a schema of
    ``encoding`` and no text), written by the mcap library."""
    values = _values()
    with path.open("wb") as f:
        writer = McapWriter(f)
        writer.start(profile="ros2", library="test")
        text = ROS2.generate_msgdef(FLOAT, ros_version=2)[0].encode()
        s0 = writer.register_schema(FLOAT, "ros2msg", text)
        s1 = writer.register_schema(CUSTOM, encoding, b"")
        channels = {
            "/s0": writer.register_channel("/s0", "cdr", s0),
            "/s1": writer.register_channel("/s1", "cdr", s1),
        }
        for i in range(N):
            for topic, channel in channels.items():
                t = T0 + i * STEP
                writer.add_message(channel, log_time=t, data=_cdr(values[topic][i]), publish_time=t)
        writer.finish()


def _mcap_bag(path: Path, encoding: str) -> Path:
    """A ROS 2 bag of MCAP storage written by rosbags, whose storage file is then that of
    :func:`_write_mcap` and whose metadata gives ``/s1`` the custom type."""
    with Ros2Writer(path, version=8, storage_plugin=StoragePlugin.MCAP) as bag:
        conns = {t: bag.add_connection(t, FLOAT, typestore=ROS2) for t in ("/s0", "/s1")}
        for i in range(N):
            for topic, conn in conns.items():
                bag.write(conn, T0 + i * STEP, _cdr(_values()[topic][i]))
    (storage,) = path.glob("*.mcap")
    _write_mcap(storage, encoding)
    meta = path / "metadata.yaml"
    pattern = rf"(name: /s1\n(?:.*\n){{2}}\s+type: ){FLOAT}"
    text, count = re.subn(pattern, rf"\g<1>{CUSTOM}", meta.read_text())
    assert count == 1
    meta.write_text(text)
    return path


def _input(tmp_path: Path, kind: str, encoding: str) -> Path:
    if kind == "mcap":
        path = tmp_path / "x.mcap"
        _write_mcap(path, encoding)
        return path
    return _mcap_bag(tmp_path / "x_bag", encoding)


SKIPPED = (
    f"/s1: unknown message type '{CUSTOM}' without definitions (give the folder that holds "
    f"{CUSTOM}.msg with --msg-path); skipped"
)


@pytest.mark.parametrize("encoding", ["unknown", ""])
@pytest.mark.parametrize("kind", ["mcap", "ros2 mcap"])
def test_a_schema_without_definition_skips_its_topic_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str, encoding: str
) -> None:
    monkeypatch.delenv(MSG_PATH_ENV, raising=False)
    reader = open_input(_input(tmp_path, kind, encoding))
    got = collect(reader.chunks())
    assert sorted(got) == ["/s0.data"]
    np.testing.assert_array_equal(got["/s0.data"][1], _values()["/s0"])
    assert reader.info.errors == [SKIPPED]


@pytest.mark.parametrize("kind", ["mcap", "ros2 mcap"])
def test_a_message_path_decodes_the_schema_without_definition(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, kind: str
) -> None:
    path = _input(tmp_path, kind, "unknown")
    msg = tmp_path / "ws" / "src" / "my_pkg" / "msg" / "Reading.msg"
    msg.parent.mkdir(parents=True)
    msg.write_text("float64 data\n")
    monkeypatch.setenv(MSG_PATH_ENV, str(tmp_path / "ws"))
    reader = open_input(path)
    got = collect(reader.chunks())
    np.testing.assert_array_equal(got["/s1.data"][1], _values()["/s1"])
    assert got["/s0.data"][1].size == N and reader.info.errors == []


def test_a_schema_of_another_kind_is_still_refused(tmp_path: Path) -> None:
    """An encoding that is no ROS definition, with text, is not taken for a missing one."""
    path = tmp_path / "x.mcap"
    with path.open("wb") as f:
        writer = McapWriter(f)
        writer.start(profile="ros2", library="test")
        text = ROS2.generate_msgdef(FLOAT, ros_version=2)[0].encode()
        s0 = writer.register_channel("/s0", "cdr", writer.register_schema(FLOAT, "ros2msg", text))
        s1 = writer.register_channel("/s1", "cdr", writer.register_schema(CUSTOM, "unknown", b"x"))
        for i in range(N):
            writer.add_message(s0, log_time=T0 + i, data=_cdr(i), publish_time=T0 + i)
            writer.add_message(s1, log_time=T0 + i, data=_cdr(i), publish_time=T0 + i)
        writer.finish()
    reader = open_input(path)
    collect(reader.chunks())
    (line,) = reader.info.errors
    assert "schema encoding 'unknown' is not a ROS message definition" in line

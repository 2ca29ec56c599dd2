"""ROS 2 bags (Iron on, sqlite3) with a ``message_definitions`` row that holds no
definition: rosbag2 writes one (encoding ``""`` or ``"unknown"``, no text) for a type it
could not find where it recorded (ros2/rosbag2#1352). The bag was refused whole
(``cannot open ROS 2 bag: ''``: rosbags' ``KeyError``); now that topic is skipped with the
line MCAP files give, or decoded from ``--msg-path``, and the rest of the bag is read
(ux58 #1, #10)."""

from __future__ import annotations

import re
import sqlite3
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import collect

from analyzer.readers import open_input
from analyzer.types import MSG_PATH_ENV
from analyzer.writers import write_archive

CUSTOM = "my_pkg/msg/Reading"
N = 2000


def _bag_without_one_definition(path: Path, encoding: str) -> np.ndarray:
    """A 2-topic ROS 2 bag written by the project's writer, whose topic ``/s1`` is then
    given the custom type ``my_pkg/msg/Reading`` (``float64 data``: the same bytes as
    ``std_msgs/msg/Float64``) with the row rosbag2 writes for a type it did not find.
    Returns ``/s1``'s values."""
    t = np.arange(N, dtype=np.int64) * 5_000_000 + 10**18
    s1 = np.cos(np.arange(N) / 7.0)
    write_archive(path, "ros2bag", t, {"s0": np.sin(np.arange(N) / 10.0), "s1": s1})
    (db,) = path.glob("*.db3")
    with sqlite3.connect(db) as conn:
        conn.execute("UPDATE topics SET type = ? WHERE name = '/s1'", (CUSTOM,))
        conn.execute(
            "INSERT INTO message_definitions (topic_type, encoding, "
            "encoded_message_definition, type_description_hash) VALUES (?, ?, '', '')",
            (CUSTOM, encoding),
        )
    meta = path / "metadata.yaml"
    pattern = r"(name: /s1\n(?:.*\n){2}\s+type: )std_msgs/msg/Float64"
    text, count = re.subn(pattern, rf"\g<1>{CUSTOM}", meta.read_text())
    assert count == 1
    meta.write_text(text)
    return s1


@pytest.mark.parametrize("encoding", ["", "unknown"])
def test_a_type_without_definition_skips_its_topic_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, encoding: str
) -> None:
    monkeypatch.delenv(MSG_PATH_ENV, raising=False)
    bag = tmp_path / "nodef"
    _bag_without_one_definition(bag, encoding)
    reader = open_input(bag)
    got = collect(reader.chunks())
    assert sorted(got) == ["/s0.data"]
    assert got["/s0.data"][1].size == N
    assert reader.info.errors == [
        f"/s1: unknown message type '{CUSTOM}' without definitions (give the folder that "
        f"holds {CUSTOM}.msg with --msg-path); skipped"
    ]


def test_a_message_path_decodes_the_type_without_definition(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    bag = tmp_path / "nodef"
    s1 = _bag_without_one_definition(bag, "")
    msg = tmp_path / "ws" / "src" / "my_pkg" / "msg" / "Reading.msg"
    msg.parent.mkdir(parents=True)
    msg.write_text("float64 data\n")
    monkeypatch.setenv(MSG_PATH_ENV, str(tmp_path / "ws"))
    reader = open_input(bag)
    got = collect(reader.chunks())
    np.testing.assert_array_equal(got["/s1.data"][1], s1)
    assert got["/s0.data"][1].size == N and reader.info.errors == []


def test_the_file_is_not_written(tmp_path: Path) -> None:
    """The rows are hidden from rosbags by a temporary view, not removed."""
    bag = tmp_path / "nodef"
    _bag_without_one_definition(bag, "")
    (db,) = bag.glob("*.db3")
    before = db.read_bytes()
    collect(open_input(bag).chunks())
    assert db.read_bytes() == before
    with sqlite3.connect(db) as conn:
        sql = "SELECT encoding FROM message_definitions WHERE topic_type = ?"
        rows = conn.execute(sql, (CUSTOM,))
        assert rows.fetchall() == [("",)]


def test_an_error_without_text_says_what_failed() -> None:
    from analyzer.readers.ros2_reader import _bag_error

    line = _bag_error(KeyError(""))
    assert "KeyError" in line and line.startswith("cannot open ROS 2 bag: ")
    assert _bag_error(RuntimeError("")).endswith("RuntimeError and no message")


def test_the_msg_path_hint_is_worded_alike_for_mcap_and_ros2(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """ux58 #10: MCAP said ``(--msg-path: the directories of its package's msg/ files)``,
    ROS 2 bags ``(give the folder that holds its package's msg/ folder with --msg-path)``."""
    from mcap.writer import Writer as McapWriter

    monkeypatch.delenv(MSG_PATH_ENV, raising=False)
    bag = tmp_path / "nodef"
    _bag_without_one_definition(bag, "")
    path = tmp_path / "custom.mcap"
    with path.open("wb") as f:
        writer = McapWriter(f)
        writer.start(profile="ros2")
        channel = writer.register_channel("/s1", "cdr", writer.register_schema(CUSTOM, "", b""))
        for i in range(5):
            data = b"\x00\x01\x00\x00" + np.float64(i).tobytes()
            writer.add_message(channel, 1_000 + i, data, 1_000 + i)
        writer.finish()
    mcap = open_input(path)
    collect(mcap.chunks())
    ros2 = open_input(bag)
    assert mcap.info.errors == ros2.info.errors

"""Indexed files whose chunks overlap in time: a chunk that starts early and ends late is
read before the chunks that fall inside it (they are read by start time). With
``--time header`` its late messages reached ``TopicTracker`` before the earlier ones of
the next chunks, which its header-clock rule took for a clock stepping back: the
stretch was dropped and a false "goes back" line written (ROS_example.bag lost 48 % of
``groundtruth``). Messages now reach the tracker in log-time order (``LogOrder``).
Logs are built with the real writers (mcap, rosbags); the chunk boundaries are set by a
message whose long ``frame_id`` fills the chunk."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer as McapWriter
from readers_helpers import T0, collect
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.readers import open_input
from analyzer.readers._common import LogOrder, as_bytes_array

ROS2 = get_typestore(Stores.ROS2_HUMBLE)
ROS1 = get_typestore(Stores.ROS1_NOETIC)
V3S = "geometry_msgs/msg/Vector3Stamped"
STEP = 100_000_000  # 100 ms: a group of 30 messages spans 3 s, more than the 2 s window
CHUNK = 4000
"""Chunk size of the writers: 30 small messages stay below it, a 5000-byte frame_id fills
a chunk (the writer closes it after that message)."""

GROUPS = (list(range(30)), [30, *range(60, 90)], list(range(31, 60)))
"""The write order, one chunk per group: 0-2.9 s; 3.0 s and 6.0-8.9 s; 3.1-5.9 s. The
second chunk spans 3.0-8.9 s and is read before the third (3.1-5.9 s) that lies inside
it; stamps equal log times."""


def _message(store: Any, i: int, closes: bool, back_from: int | None) -> Any:
    ns = T0 + i * STEP - (3 * 10**9 if back_from is not None and i >= back_from else 0)
    stamp = store.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
    header_type = store.types["std_msgs/msg/Header"]
    frame = "x" * 5000 if closes else "f"
    header = (
        header_type(seq=0, stamp=stamp, frame_id=frame)
        if "seq" in header_type.__dataclass_fields__
        else header_type(stamp=stamp, frame_id=frame)
    )
    vector = store.types["geometry_msgs/msg/Vector3"](x=float(i), y=0.0, z=0.0)
    return store.types[V3S](header=header, vector=vector)


def _write(path: Path, fmt: str, back_from: int | None = None) -> Path:
    """:data:`GROUPS` on one topic ``/v``, one chunk per group; from message
    ``back_from`` on, stamped 3 s before their log time (a clock step back)."""
    order = [(i, k == len(group) - 1) for group in GROUPS for k, i in enumerate(group)]
    if fmt == "mcap":
        with path.open("wb") as handle:
            writer = McapWriter(handle, chunk_size=CHUNK)
            writer.start(profile="ros2", library="test")
            text = ROS2.generate_msgdef(V3S, ros_version=2)[0]
            channel = writer.register_channel(
                "/v", "cdr", writer.register_schema(V3S, "ros2msg", text.encode())
            )
            for i, closes in order:
                data = bytes(ROS2.serialize_cdr(_message(ROS2, i, closes, back_from), V3S))
                t = T0 + i * STEP
                writer.add_message(channel, log_time=t, data=data, publish_time=t)
            writer.finish()
    else:
        bag = Ros1Writer(path)
        bag.chunk_threshold = CHUNK
        with bag:
            conn = bag.add_connection("/v", V3S, typestore=ROS1)
            for i, closes in order:
                data = bytes(ROS1.serialize_ros1(_message(ROS1, i, closes, back_from), V3S))
                bag.write(conn, T0 + i * STEP, data)
    return path


def _spans(reader: Any) -> list[tuple[float, float]]:
    """The chunks' (start, end) in seconds after T0, in file order."""
    if hasattr(reader, "_chunk_infos"):
        infos = sorted(reader._chunk_infos, key=lambda c: c.pos)
        pairs = [(c.start_ns, c.end_ns) for c in infos]
    else:
        with reader.path.open("rb") as handle:
            indexes = make_reader(handle).get_summary().chunk_indexes
        indexes = sorted(indexes, key=lambda c: c.chunk_start_offset)
        pairs = [(c.message_start_time, c.message_end_time) for c in indexes]
    return [(round((a - T0) / 1e9, 1), round((b - T0) / 1e9, 1)) for a, b in pairs]


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
@pytest.mark.parametrize("time", ["header", "log"])
def test_overlapping_chunks_keep_every_message(tmp_path: Path, fmt: str, time: str) -> None:
    """All 90 messages, in order, nothing said (the 29 of the third chunk were dropped as
    "header.stamp goes back by 5.8 s")."""
    path = _write(tmp_path / ("x.mcap" if fmt == "mcap" else "x.bag"), fmt)
    reader = open_input(path)
    assert _spans(reader) == [(0.0, 2.9), (3.0, 8.9), (3.1, 5.9)]
    t, v = collect(reader.chunks(time))["/v.vector.x"]
    assert v.tolist() == list(range(90))
    assert t.tolist() == [T0 + i * STEP for i in range(90)]
    assert reader.info.errors == []


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_overlapping_chunks_still_find_a_real_clock_step(tmp_path: Path, fmt: str) -> None:
    """The same chunks, and the header clock steps back 3 s at message 45 (in the third
    chunk, read last): the step is found where it is in log time; 45-74 (stamped at or
    before the newest stamp, 4.4 s) are dropped, 75-89 kept."""
    path = _write(tmp_path / ("x.mcap" if fmt == "mcap" else "x.bag"), fmt, back_from=45)
    reader = open_input(path)
    t, v = collect(reader.chunks("header"))["/v.vector.x"]
    assert v.tolist() == list(range(45)) + list(range(75, 90))
    assert reader.info.errors == [
        "/v: header.stamp goes back by 2.9 s at message 45 (t=4.50 s); 30 messages stamped "
        "before the newest stamp so far dropped (--time log keeps them)"
    ]


def _undecoded(log: list[int]) -> tuple[Any, Any, Any, Any]:
    buf = as_bytes_array(bytes(range(len(log))))
    starts = np.arange(len(log), dtype=np.int64)
    return buf, starts, np.ones(len(log), dtype=np.int64), np.asarray(log, dtype=np.int64)


def test_log_order_holds_what_a_later_chunk_may_precede() -> None:
    """A batch's messages after the bound wait; taken with the next batch's, they
    come out in log-time order, their payloads with them."""
    gate = LogOrder()
    gate.push(7, *_undecoded([30, 60, 61, 62]))
    taken = list(gate.take(30))  # (one logged at the bound itself goes)
    assert [(k, log.tolist()) for k, _, _, _, log in taken] == [(7, [30])]
    gate.push(7, *_undecoded([31, 59, 63]))
    ((key, buf, starts, sizes, log),) = list(gate.take(None))
    assert key == 7 and log.tolist() == [31, 59, 60, 61, 62, 63]
    payload: Callable[[int], int] = lambda j: int(buf[starts[j]])  # noqa: E731
    # payload bytes: the first batch's 1, 2, 3 (at 60, 61, 62), the second's 0, 1, 2
    assert [payload(j) for j in range(6)] == [0, 1, 1, 2, 3, 2]
    assert sizes.tolist() == [1] * 6
    assert list(gate.take(None)) == []


@pytest.mark.realdata
def test_ros_example_header_time_keeps_groundtruth(corpus: Path) -> None:
    """ROS_example.bag: a chunk spanning 9.5-889 s holds groundtruth's last 583 messages
    (814-889 s) and is read before the chunk of 425-814 s. Its stamps equal its log times:
    with --time header all 12765 are kept and nothing is said (6668 were, with a false
    "goes back by 463.4 s")."""
    reader = open_input(corpus / "ros1/evo/ROS_example.bag")
    samples = collect(reader.chunks("header"))
    counts = {name.split(".")[0]: t.size for name, (t, _) in samples.items()}
    assert counts == {"groundtruth": 12765, "ORB-SLAM": 8362, "S-PTAM": 5439}
    assert reader.info.errors == []
    t, _ = samples["groundtruth.pose.position.x"]
    reader = open_input(corpus / "ros1/evo/ROS_example.bag")
    t_log, _ = collect(reader.chunks("log"))["groundtruth.pose.position.x"]
    assert np.array_equal(t, t_log)  # (its stamps are its log times)


def test_log_order_keeps_held_payloads_in_a_buffer_of_their_own() -> None:
    """A part held across chunks keeps its payloads, not its chunk's whole buffer (the
    review: a topic logged 200 s behind the others kept every chunk alive), and a part
    whose earliest message is after the bound waits as it is."""
    gate = LogOrder()
    buf = as_bytes_array(bytes(range(200)))
    starts = np.array([10, 100, 150], dtype=np.int64)
    gate.push(3, buf, starts, np.array([2, 3, 4], dtype=np.int64), np.array([5, 50, 60]))
    assert [log.tolist() for _, _, _, _, log in gate.take(10)] == [[5]]
    ((_, held_buf, held_starts, sizes, log),) = list(gate.take(None))
    assert held_buf.shape[0] == 7  # 3 + 4 payload bytes, not 200
    assert [bytes(held_buf[s : s + n]) for s, n in zip(held_starts, sizes, strict=True)] == [
        bytes(range(100, 103)),
        bytes(range(150, 154)),
    ]
    gate.push(4, buf, starts[:1], np.array([2]), np.array([90]))
    assert list(gate.take(80)) == []
    assert [log.tolist() for _, _, _, _, log in gate.take(None)] == [[90]]

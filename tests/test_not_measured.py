"""Fields of log messages and times written in messages are not measurements: a default
run leaves them out, as it does counters and flags, with ``why`` ``log message field`` or
``timestamp field``; ``--channels`` naming them keeps them (a new user's audit, ux52
item 10: ``/rosout.level``, ``/rosout.line`` and Foxglove's ``timestamp.sec``/``nsec``
were analyzed as sensors, set the common clock at 321 Hz and had the run advise leaving
out the only real signal; Keelson's 83 ``timestamp.seconds``/``.nanos`` were a record's
only default channels). The rule is the message's type (``rosgraph_msgs/Log``,
``rcl_interfaces/msg/Log``, ``foxglove.Log``) and the time's shape (seconds beside
nanoseconds; a ``stamp`` that never goes back), not one file's names."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.cli import main
from analyzer.errors import ArchiveUsageError
from analyzer.readers import open_archive
from analyzer.selection import left_out, select_channels
from analyzer.store import ChannelStore

N = 300
T0 = 1_700_000_000_000_000_000
STEP = 20_000_000  # 50 Hz
RNG = np.random.default_rng(7)
SENSOR = RNG.standard_normal((N, 2))
LEVELS = RNG.choice([1, 2, 4, 8], N)
LINES = RNG.integers(10, 500, N)


def _ros1_bag(path: Path) -> Path:
    """A ROS 1 bag: ``/rosout`` (``rosgraph_msgs/Log``, several levels and lines)
    beside two ``Float64`` sensors, the log published at 5 times their rate."""
    store = get_typestore(Stores.ROS1_NOETIC)
    log = store.types["rosgraph_msgs/msg/Log"]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    f64 = store.types["std_msgs/msg/Float64"]
    with Ros1Writer(path) as bag:
        out = bag.add_connection("/rosout", "rosgraph_msgs/msg/Log", typestore=store)
        s = [bag.add_connection(f"/s{k}", "std_msgs/msg/Float64", typestore=store) for k in (0, 1)]
        for i in range(N):
            t = T0 + i * STEP
            for k in (0, 1):
                data = store.serialize_ros1(f64(data=float(SENSOR[i, k])), "std_msgs/msg/Float64")
                bag.write(s[k], t, bytes(data))
            for j in range(5):
                tj = t + j * STEP // 5
                msg = log(
                    header=header(
                        seq=i, stamp=stamp(sec=tj // 10**9, nanosec=tj % 10**9), frame_id=""
                    ),
                    level=int(LEVELS[(i + j) % N]),
                    name="/node",
                    msg="hello",
                    file="node.cpp",
                    function="f",
                    line=int(LINES[(i + j) % N]),
                    topics=[],
                )
                bag.write(out, tj, bytes(store.serialize_ros1(msg, "rosgraph_msgs/msg/Log")))
    return path


def _ros2_bag(path: Path) -> Path:
    """A ROS 2 bag: ``/rosout`` (``rcl_interfaces/msg/Log``: its own ``stamp`` too)
    beside two ``Float64`` sensors."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    log = store.types["rcl_interfaces/msg/Log"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    f64 = store.types["std_msgs/msg/Float64"]
    with Ros2Writer(path, version=9) as bag:
        out = bag.add_connection("/rosout", "rcl_interfaces/msg/Log", typestore=store)
        s = [bag.add_connection(f"/s{k}", "std_msgs/msg/Float64", typestore=store) for k in (0, 1)]
        for i in range(N):
            t = T0 + i * STEP
            for k in (0, 1):
                data = store.serialize_cdr(f64(data=float(SENSOR[i, k])), "std_msgs/msg/Float64")
                bag.write(s[k], t, bytes(data))
            msg = log(
                stamp=stamp(sec=t // 10**9, nanosec=t % 10**9),
                level=int(LEVELS[i]),
                name="/node",
                msg="hello",
                file="node.cpp",
                function="f",
                line=int(LINES[i]),
            )
            bag.write(out, t, bytes(store.serialize_cdr(msg, "rcl_interfaces/msg/Log")))
    return path


def _json_mcap(path: Path) -> Path:
    """A JSON MCAP as Foxglove writes one: ``/rosout`` (``foxglove.Log``, its
    ``timestamp`` as ``{sec, nsec}``), a ``pose`` topic that stamps each message (``{sec,
    nsec}``, a protobuf-style ``{seconds, nanos}`` and a ``stamp`` in seconds) and a
    ``wave`` whose field named ``stamp`` goes up and down (a measurement: kept)."""
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="", library="test")
        ids = {}
        for topic, schema in (("/rosout", "foxglove.Log"), ("pose", "Pose"), ("wave", "Wave")):
            sid = writer.register_schema(schema, "jsonschema", b"{}")
            ids[topic] = writer.register_channel(topic, "json", sid)
        for i in range(N):
            t = T0 + i * STEP
            sec, nsec = divmod(t, 10**9)
            rows = {
                "/rosout": {
                    "timestamp": {"sec": sec, "nsec": nsec},
                    "level": int(LEVELS[i]),
                    "message": "m",
                },
                "pose": {
                    "meta": {"time": {"sec": sec, "nsec": nsec}},
                    "taken": {"seconds": sec, "nanos": nsec},
                    "stamp": t / 1e9,
                    "x": float(SENSOR[i, 0]),
                    "y": float(SENSOR[i, 1]),
                },
                "wave": {"stamp": float(np.sin(i / 7.0)), "sec": float(np.cos(i / 5.0))},
            }
            for topic, row in rows.items():
                writer.add_message(ids[topic], t, json.dumps(row).encode(), t)
        writer.finish()
    return path


def _inspected(path: Path, capsys) -> dict:
    assert main(["inspect", str(path), "--json"]) == 0
    return json.loads(capsys.readouterr().out)


def _whys(report: dict) -> dict[str, str | None]:
    return {c["name"]: c.get("why") for c in report["channels"]}


@pytest.mark.parametrize("make", [_ros1_bag, _ros2_bag], ids=["ros1", "ros2"])
def test_a_ros_log_topic_is_left_out_by_its_type(tmp_path, capsys, make):
    report = _inspected(make(tmp_path / "rec.bag"), capsys)
    whys = _whys(report)
    logs = {n: w for n, w in whys.items() if n.startswith("/rosout")}
    assert "/rosout.line" in logs and "/rosout.level" in logs
    assert set(logs.values()) == {"log message field"}, logs
    assert whys["/s0.data"] is None and whys["/s1.data"] is None
    # (the log, 5 times faster in ROS 1, no longer sets the clock)
    assert report["run_defaults"]["channels"] == 2
    assert report["run_defaults"]["rate_hz"] == pytest.approx(50.0, rel=1e-3)


def test_times_written_in_messages_are_left_out_and_a_varying_stamp_is_kept(tmp_path, capsys):
    report = _inspected(_json_mcap(tmp_path / "rec.mcap"), capsys)
    whys = _whys(report)
    assert whys["/rosout.level"] == "log message field"
    assert whys["/rosout.timestamp.sec"] == "log message field"
    for name in (
        "pose.meta.time.sec",
        "pose.meta.time.nsec",
        "pose.taken.seconds",
        "pose.taken.nanos",
        "pose.stamp",
    ):
        assert whys[name] == "timestamp field", (name, whys)
    # (measurements whatever their names: a stamp that goes back, a sec alone)
    for name in ("pose.x", "pose.y", "wave.stamp", "wave.sec"):
        assert whys[name] is None, (name, whys)
    assert report["run_defaults"]["channels"] == 4


def _store(path: Path):
    archive = open_archive([path])
    return archive, ChannelStore.from_chunks(archive.chunks("log"))


def test_channels_naming_them_keeps_them_and_the_note_says_why(tmp_path):
    archive, store = _store(_json_mcap(tmp_path / "rec.mcap"))
    logs = [t for i in archive.inputs for t in i.log_topics]
    assert logs == ["/rosout"]
    with store:
        notes: list[str] = []
        chosen = select_channels(store, None, notes, log_topics=logs)
        assert "pose.taken.nanos" not in chosen and "/rosout.level" not in chosen
        why = left_out(notes, {i.name: i for i in store.infos()})
        assert why["pose.taken.nanos"] == {"why": "timestamp field"}
        assert why["/rosout.level"] == {"why": "log message field"}
        said = [n for n in notes if "not measurements" in n]
        assert len(said) == 1 and "--channels naming them analyzes them" in said[0]
        named = select_channels(
            store, ["/rosout.level", "pose.taken.*", "pose.x"], [], log_topics=logs
        )
        assert named == ["/rosout.level", "pose.taken.seconds", "pose.taken.nanos", "pose.x"]
        # ('!' patterns alone leave out of the default channels: these stay out)
        assert "pose.stamp" not in select_channels(store, ["!wave.*"], [], log_topics=logs)


def test_a_record_of_timestamps_only_is_refused_saying_so(tmp_path):
    path = tmp_path / "stamps.mcap"
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="", library="test")
        cid = writer.register_channel(
            "ais", "json", writer.register_schema("Ais", "jsonschema", b"{}")
        )
        for i in range(N):
            t = T0 + i * 333_000_000
            row = {"timestamp": {"seconds": t // 10**9, "nanos": t % 10**9}}
            writer.add_message(cid, t, json.dumps(row).encode(), t)
        writer.finish()
    archive, store = _store(path)
    # (what the record holds: timestamps only, not "a log message's field or a timestamp")
    with (
        store,
        pytest.raises(
            ArchiveUsageError, match="every varying channel is a timestamp, not a measurement"
        ),
    ):
        select_channels(store, None, [], log_topics=[])


def test_run_leaves_them_out_too(tmp_path, capsys):
    """``run`` selects as ``inspect`` says: of the log and one sensor, one channel is
    left (refused as one, naming the log's fields), where the log's level and line were
    analyzed beside it."""
    store = get_typestore(Stores.ROS1_NOETIC)
    log = store.types["rosgraph_msgs/msg/Log"]
    header = store.types["std_msgs/msg/Header"]
    stamp = store.types["builtin_interfaces/msg/Time"]
    f64 = store.types["std_msgs/msg/Float64"]
    path = tmp_path / "one.bag"
    with Ros1Writer(path) as bag:
        out = bag.add_connection("/rosout", "rosgraph_msgs/msg/Log", typestore=store)
        s0 = bag.add_connection("/s0", "std_msgs/msg/Float64", typestore=store)
        for i in range(N):
            t = T0 + i * STEP
            data = store.serialize_ros1(f64(data=float(SENSOR[i, 0])), "std_msgs/msg/Float64")
            bag.write(s0, t, bytes(data))
            head = header(seq=i, stamp=stamp(sec=t // 10**9, nanosec=t % 10**9), frame_id="")
            msg = log(
                header=head,
                level=int(LEVELS[i]),
                name="/n",
                msg="m",
                file="f",
                function="g",
                line=int(LINES[i]),
                topics=[],
            )
            bag.write(out, t, bytes(store.serialize_ros1(msg, "rosgraph_msgs/msg/Log")))
    code = main(["run", str(path), "--out", str(tmp_path / "o"), "--no-progress"])
    err = capsys.readouterr().err
    assert code == 2
    assert "one channel to analyze (/s0.data)" in err, err
    # (log fields only: "and timestamps" named what was not there)
    assert "; log messages' fields not analyzed: /rosout.level, /rosout.line" in err

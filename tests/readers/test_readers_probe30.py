"""The readers against the 30th probe's findings: header clocks that jump back or are
unset, repeated timestamps, ``name[]`` arrays that change order, ROS 2 bag folders
(unlisted, misordered, overlapping or FIFO storage files), several MCAP channels on one
topic, and the warnings of ``export``. Logs are built with the real writers."""

from __future__ import annotations

import json
import os
import re
import shutil
import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import yaml
from mcap.writer import Writer as McapWriter
from readers_helpers import T0, collect
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from analyzer.cli import main
from analyzer.errors import ReaderError
from analyzer.readers import open_archive, open_input
from analyzer.readers._common import Reorderer, TopicTracker, concat_payloads
from analyzer.readers.rosdecode import RosBatchDecoder

ROS2 = get_typestore(Stores.ROS2_HUMBLE)
ROS1 = get_typestore(Stores.ROS1_NOETIC)
V3S = "geometry_msgs/msg/Vector3Stamped"
JS = "sensor_msgs/msg/JointState"
MS = 10_000_000  # 10 ms: 100 Hz

Message = tuple[str, str, int, Any]
"""(topic, type, log time ns, a function of the typestore giving the message)"""


def _header(store: Any, ns: int) -> Any:
    stamp = store.types["builtin_interfaces/msg/Time"](sec=ns // 10**9, nanosec=ns % 10**9)
    header = store.types["std_msgs/msg/Header"]
    if "seq" in header.__dataclass_fields__:
        return header(seq=0, stamp=stamp, frame_id="f")
    return header(stamp=stamp, frame_id="f")


def v3s(stamp_ns: int, x: float) -> Callable[[Any], Any]:
    def make(store: Any) -> Any:
        vector = store.types["geometry_msgs/msg/Vector3"](x=float(x), y=0.0, z=0.0)
        return store.types[V3S](header=_header(store, stamp_ns), vector=vector)

    return make


def joint_state(stamp_ns: int, names: Sequence[str], pos: Sequence[float]) -> Callable[[Any], Any]:
    def make(store: Any) -> Any:
        p = np.asarray(pos, dtype=np.float64)
        return store.types[JS](
            header=_header(store, stamp_ns),
            name=list(names),
            position=p,
            velocity=p * 0.1,
            effort=np.zeros(0),
        )

    return make


def write_mcap(path: Path, messages: Sequence[Message] | Any, **options: Any) -> Path:
    """``messages`` as an MCAP (ROS 2 profile); ``options`` for mcap's writer (its
    ``chunk_size``, ``index_types``)."""
    with path.open("wb") as handle:
        writer = McapWriter(handle, **options)
        writer.start(profile="ros2", library="test")
        channels: dict[str, int] = {}
        for topic, msgtype, t, make in messages:
            if topic not in channels:
                text = ROS2.generate_msgdef(msgtype, ros_version=2)[0]
                schema = writer.register_schema(msgtype, "ros2msg", text.encode())
                channels[topic] = writer.register_channel(topic, "cdr", schema)
            data = bytes(ROS2.serialize_cdr(make(ROS2), msgtype))
            writer.add_message(channels[topic], log_time=t, data=data, publish_time=t)
        writer.finish()
    return path


def write(path: Path, fmt: str, messages: Sequence[Message]) -> Path:
    """``messages`` as an MCAP (ROS 2 profile), a ROS 1 bag or a ROS 2 bag (sqlite3, or
    ``ros2 mcap``: MCAP storage)."""
    if fmt == "mcap":
        write_mcap(path, messages)
    elif fmt == "ros1":
        with Ros1Writer(path) as bag:
            conns: dict[str, Any] = {}
            for topic, msgtype, t, make in messages:
                if topic not in conns:
                    conns[topic] = bag.add_connection(topic, msgtype, typestore=ROS1)
                bag.write(conns[topic], t, bytes(ROS1.serialize_ros1(make(ROS1), msgtype)))
    else:
        plugin = StoragePlugin.MCAP if fmt == "ros2 mcap" else StoragePlugin.SQLITE3
        with Ros2Writer(path, version=9, storage_plugin=plugin) as bag:
            conns = {}
            for topic, msgtype, t, make in messages:
                if topic not in conns:
                    conns[topic] = bag.add_connection(topic, msgtype, typestore=ROS2)
                bag.write(conns[topic], t, bytes(ROS2.serialize_cdr(make(ROS2), msgtype)))
    return path


NAMES = {"mcap": "x.mcap", "ros1": "x.bag", "ros2": "x_bag"}


# --------------------------------------------------------------------------- #2, #8


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_header_clock_jump_back_drops_the_stretch_behind(tmp_path: Path, fmt: str) -> None:
    """The header clock steps back 3 s at message 200: messages 200..499 are stamped
    before the newest stamp (1.99 s) and would interleave with 0..199; they are dropped
    and reported, 500..599 (past 1.99 s again) are kept."""
    messages = [
        ("/back", V3S, T0 + i * MS, v3s(T0 + i * MS - (3 * 10**9 if i >= 200 else 0), i))
        for i in range(600)
    ]
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    t, v = collect(reader.chunks("header"))["/back.vector.x"]
    assert v.tolist() == list(range(200)) + list(range(500, 600))
    assert bool(np.all(np.diff(t) > 0))
    assert reader.info.errors == [
        "/back: header.stamp goes back by 3.0 s at message 200 (t=2.00 s); 300 messages "
        "stamped before the newest stamp so far dropped (--time log keeps them)"
    ]
    # the log clock has no jump: everything, nothing to say
    reader = open_input(reader.info.path)
    assert collect(reader.chunks("log"))["/back.vector.x"][1].size == 600
    assert reader.info.errors == []


def test_header_jitter_within_the_window_is_reordered_not_dropped(tmp_path: Path) -> None:
    """Stamps that go back by less than the reorder window (two stamps swapped) are
    sorted, as before: nothing dropped, nothing to say."""
    stamps = [T0 + i * MS for i in range(300)]
    stamps[100], stamps[101] = stamps[101], stamps[100]
    messages = [("/j", V3S, T0 + i * MS, v3s(stamps[i], i)) for i in range(300)]
    reader = open_input(write(tmp_path / "j.mcap", "mcap", messages))
    t, v = collect(reader.chunks("header"))["/j.vector.x"]
    assert t.tolist() == sorted(stamps) and v[100:102].tolist() == [101.0, 100.0]
    assert reader.info.errors == []


def test_header_jump_across_batches(tmp_path: Path) -> None:
    """The stretch behind the newest stamp is followed from one batch (MCAP chunk) to the
    next: the same samples are dropped as in one batch."""
    messages = [
        ("/back", V3S, T0 + i * MS, v3s(T0 + i * MS - (3 * 10**9 if i >= 200 else 0), i))
        for i in range(600)
    ]
    path = tmp_path / "small_chunks.mcap"
    with path.open("wb") as handle:
        writer = McapWriter(handle, chunk_size=2000)
        writer.start(profile="ros2", library="test")
        text = ROS2.generate_msgdef(V3S, ros_version=2)[0]
        channel = writer.register_channel(
            "/back", "cdr", writer.register_schema(V3S, "ros2msg", text.encode())
        )
        for _, msgtype, t, make in messages:
            writer.add_message(
                channel,
                log_time=t,
                data=bytes(ROS2.serialize_cdr(make(ROS2), msgtype)),
                publish_time=t,
            )
        writer.finish()
    reader = open_input(path)
    v = collect(reader.chunks("header"))["/back.vector.x"][1]
    assert v.tolist() == list(range(200)) + list(range(500, 600))
    assert len(reader.info.errors) == 1 and "300 messages" in reader.info.errors[0]


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_zero_header_stamp_is_no_stamp(tmp_path: Path, fmt: str) -> None:
    """header.stamp 0 (a driver not yet synced): the log time is used, and counted."""
    messages = [
        ("/z", V3S, T0 + i * MS, v3s(0 if 50 <= i < 60 else T0 + i * MS - MS // 2, i))
        for i in range(200)
    ]
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    t, _ = collect(reader.chunks("header"))["/z.vector.x"]
    expected = [T0 + i * MS - (0 if 50 <= i < 60 else MS // 2) for i in range(200)]
    assert t.tolist() == sorted(expected)
    assert reader.info.errors == [
        "/z: 10 messages have header.stamp 0 (not set); their log time is used"
    ]


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_repeated_timestamps_are_counted(tmp_path: Path, fmt: str) -> None:
    """Every message twice at the same time (values i and i + 0.5): both are raw samples
    (inspect counts them), but one value per time is what aligned channels hold: said."""
    messages = [
        ("/dup", V3S, T0 + i * MS, v3s(T0 + i * MS, i + half))
        for i in range(100)
        for half in (0, 0.5)
    ]
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    t, _ = collect(reader.chunks("log"))["/dup.vector.x"]
    assert t.size == 200
    assert reader.info.errors == [
        "/dup: 100 messages repeat the timestamp of the one before (two publishers, or a "
        "recorder's coarse clock); the aligned channels keep one value per time"
    ]


# --------------------------------------------------------------------------- #3


def _joint_messages() -> list[Message]:
    out = []
    for i in range(1000):
        t = T0 + i * MS
        if i < 300:
            names, pos = ["a", "b", "c"], [1000.0 + i, -1000.0 - i, 5000.0]
        elif i < 600:
            names, pos = ["b", "a", "c"], [-1000.0 - i, 1000.0 + i, 5000.0]
        else:
            names, pos = ["a", "b"], [1000.0 + i, -1000.0 - i]
        out.append(("/joint_states", JS, t, joint_state(t, names, pos)))
    return out


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_joint_name_order_change_is_reported(tmp_path: Path, fmt: str) -> None:
    """The values are put back in the first order by name (rob56 #2: they followed the
    index, and the channels were left out)."""
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, _joint_messages()))
    got = collect(reader.chunks())
    assert got["/joint_states.position[0]"][1].size == 1000  # (named by index: the contract)
    np.testing.assert_array_equal(got["/joint_states.position[0]"][1], 1000.0 + np.arange(1000))
    assert reader.info.errors == [
        "/joint_states: name[] changed order at t=3.00 s ([a, b, c] -> [b, a, c]); 2 changes; "
        "position[i], velocity[i] put back in the first order by name, [a, b, c]; missing: c "
        "from t=6.00 s"
    ]
    assert reader.info.relabelled == []


def test_joint_names_that_stay_say_nothing(tmp_path: Path) -> None:
    messages = [
        ("/js", JS, T0 + i * MS, joint_state(T0 + i * MS, ["a", "b"], [i, -i])) for i in range(300)
    ]
    reader = open_input(write(tmp_path / "same.mcap", "mcap", messages))
    collect(reader.chunks())
    assert reader.info.errors == []


def test_joint_name_change_between_batches() -> None:
    """The first message of a batch is compared with the last of the topic's batch
    before (by the topic's tracker: of any decoder, i.e. publisher)."""
    decoders = [RosBatchDecoder([ROS2], JS, "cdr") for _ in range(2)]
    tracker = TopicTracker("log")

    def batch(names: list[str], which: int = 0) -> Any:
        payloads = [
            bytes(ROS2.serialize_cdr(joint_state(T0 + i, names, [1.0, 2.0])(ROS2), JS))
            for i in range(5)
        ]
        decoded = decoders[which].decode(*concat_payloads(payloads))
        assert decoded.relabels == []  # (no change inside a batch)
        tracker.push(Reorderer(), "/js", decoded, np.arange(5, dtype=np.int64) + T0)
        return tracker.lines()

    assert batch(["left", "right"]) == []
    assert batch(["left", "right"]) == []
    (line,) = batch(["right", "left"])
    assert line.startswith("/js: name[] changed order at")
    assert "([left, right] -> [right, left])" in line
    assert "position[i], velocity[i] put back in the first order by name" in line
    # a second publisher whose names differ: the same topic's names change
    assert "; 2 changes" in batch(["left", "right"], which=1)[0]
    assert tracker.relabelled() == []


# --------------------------------------------------------------------------- #4, #5, #9, FIFO


def _imu_like(start: int, stop: int) -> list[Message]:
    return [("/v", V3S, T0 + i * MS, v3s(T0 + i * MS, i)) for i in range(start, stop)]


def _split_bag(tmp_path: Path, parts: Sequence[tuple[int, int]], listed: Sequence[int]) -> Path:
    """A bag folder with one storage file per part (``b_{k}.db3``); metadata.yaml lists
    the files ``listed`` in that order."""
    bag = tmp_path / "split"
    bag.mkdir()
    meta: dict[str, Any] = {}
    for k, (start, stop) in enumerate(parts):
        one = write(tmp_path / f"part{k}", "ros2", _imu_like(start, stop))
        shutil.move(next(one.glob("*.db3")), bag / f"b_{k}.db3")
        meta = yaml.safe_load((one / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    info["relative_file_paths"] = [f"b_{k}.db3" for k in listed]
    info["files"] = []
    (bag / "metadata.yaml").write_text(yaml.safe_dump(meta))
    return bag


def test_ros2_split_files_are_read_in_time_order(tmp_path: Path) -> None:
    bag = _split_bag(tmp_path, [(0, 100), (100, 200), (200, 300)], listed=[2, 0, 1])
    reader = open_input(bag)
    v = collect(reader.chunks())["/v.vector.x"][1]
    assert v.tolist() == list(range(300))
    assert reader.info.errors == []


def test_ros2_unlisted_storage_file_is_reported(tmp_path: Path) -> None:
    bag = _split_bag(tmp_path, [(0, 100), (100, 200)], listed=[0])
    reader = open_input(bag)
    assert collect(reader.chunks())["/v.vector.x"][1].size == 100
    assert reader.info.errors == [
        "b_1.db3: in the bag folder but not in metadata.yaml; not read (give it as an input "
        "of its own to read it)"
    ]
    # given as an input of its own, it is read, after the bag
    archive = open_archive([bag, bag / "b_1.db3"])
    assert collect(archive.chunks())["/v.vector.x"][1].size == 200


def test_ros2_overlapping_split_files_one_line_per_topic_and_file(tmp_path: Path) -> None:
    bag = _split_bag(tmp_path, [(0, 150), (100, 200)], listed=[0, 1])
    archive = open_archive(bag)
    v = collect(archive.chunks())["/v.vector.x"][1]
    assert v.tolist() == list(range(200))
    assert archive.inputs[0].errors == [
        "b_1.db3: /v: 50 messages overlap an earlier split file of the bag in time; dropped"
    ]


def test_archive_overlap_one_line_per_topic(tmp_path: Path) -> None:
    write(tmp_path / "a.mcap", "mcap", _imu_like(0, 150))
    write(tmp_path / "b.mcap", "mcap", _imu_like(100, 200))
    archive = open_archive(tmp_path)
    assert collect(archive.chunks())["/v.vector.z"][1].size == 200
    assert archive.inputs[1].errors == [
        "/v: 50 messages overlap the previous input in time (490 ms that a.mcap covers "
        "already; its samples are kept); dropped"
    ]


def test_ros2_fifo_storage_file_is_refused(tmp_path: Path) -> None:
    """rosbags would open the listed storage file: a FIFO would block it forever."""
    bag = write(tmp_path / "bag", "ros2", _imu_like(0, 10))
    storage = next(bag.glob("*.db3"))
    storage.unlink()
    os.mkfifo(storage)
    outcome: list[BaseException | None] = []

    def attempt() -> None:
        try:
            open_input(bag)
            outcome.append(None)
        except BaseException as err:  # noqa: BLE001 - checked below
            outcome.append(err)

    thread = threading.Thread(target=attempt, daemon=True)
    thread.start()
    thread.join(20)
    if thread.is_alive():  # let the blocked open go (a writer comes), then fail
        fd = os.open(storage, os.O_WRONLY | os.O_NONBLOCK)
        os.close(fd)
        pytest.fail("opening a bag whose storage file is a FIFO blocked")
    (err,) = outcome
    assert isinstance(err, ReaderError)
    assert re.fullmatch(
        rf"{re.escape(str(bag))}: {storage.name}: not a regular file \(a FIFO\): not read",
        str(err),
    )


# --------------------------------------------------------------------------- #6


def _two_channels(path: Path, second_type: str) -> Path:
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="ros2", library="test")
        ids = []
        for msgtype in (V3S, second_type):
            text = ROS2.generate_msgdef(msgtype, ros_version=2)[0]
            schema = writer.register_schema(msgtype, "ros2msg", text.encode())
            ids.append((writer.register_channel("/imu", "cdr", schema), msgtype))
        for i in range(100):
            t = T0 + i * MS
            for k, (cid, msgtype) in enumerate(ids):
                if msgtype == V3S:
                    msg = v3s(t + k * 1000, k)(ROS2)
                else:
                    msg = ROS2.types[msgtype](data=float(i))
                data = bytes(ROS2.serialize_cdr(msg, msgtype))
                writer.add_message(cid, log_time=t + k * 1000, data=data, publish_time=t)
        writer.finish()
    return path


def test_mcap_publishers_sharing_a_topic_are_reported(tmp_path: Path) -> None:
    reader = open_input(_two_channels(tmp_path / "two.mcap", V3S))
    assert collect(reader.chunks())["/imu.vector.x"][1].size == 200
    assert reader.info.errors == ["/imu: 2 MCAP channels (publishers) share this topic; merged"]
    # two types on one topic give channels of different names: nothing merged
    reader = open_input(_two_channels(tmp_path / "types.mcap", "std_msgs/msg/Float64"))
    got = collect(reader.chunks())
    assert got["/imu.vector.x"][1].size == 100 and got["/imu.data"][1].size == 100
    assert reader.info.errors == []


# --------------------------------------------------------------------------- #7


def test_export_warns_about_its_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    folder = tmp_path / "in"
    folder.mkdir()
    write(folder / "a.mcap", "mcap", _imu_like(0, 300))
    write(folder / "b.mcap", "mcap", _imu_like(200, 400))
    out = tmp_path / "out.csv"
    assert main(["export", str(folder), "--out", str(out)]) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0] == (
        f"analyzer: warning: {folder / 'b.mcap'}: /v: 100 messages overlap the previous "
        "input in time (990 ms that a.mcap covers already; its samples are kept); dropped"
    )
    assert len(err) == 2 and err[1].startswith("analyzer: exported ")  # (its last line)
    assert out.is_file()


# ------------------------------------------------------------ an array's element renamed

TF = "tf2_msgs/msg/TFMessage"
DIAG = "diagnostic_msgs/msg/DiagnosticArray"
if TF not in ROS1.types:  # (not in the Noetic store: tf2_msgs is a package of its own)
    ROS1.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms", TF))


def tf_message(stamp_ns: int, frames: Sequence[tuple[str, str, float]]) -> Callable[[Any], Any]:
    """A TFMessage of one transform per (parent, child, x)."""

    def make(store: Any) -> Any:
        out = []
        for parent, child, x in frames:
            header = _header(store, stamp_ns)
            header.frame_id = parent
            tr = store.types["geometry_msgs/msg/Vector3"](x=float(x), y=0.0, z=0.0)
            rot = store.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
            transform = store.types["geometry_msgs/msg/Transform"](translation=tr, rotation=rot)
            out.append(
                store.types["geometry_msgs/msg/TransformStamped"](
                    header=header, child_frame_id=child, transform=transform
                )
            )
        return store.types[TF](transforms=out)

    return make


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
@pytest.mark.parametrize("children", [("a", "b"), ("base_link", "odom")])
def test_a_transform_whose_frame_changes_is_said_and_marked(
    tmp_path: Path, fmt: str, children: tuple[str, str]
) -> None:
    """Real-data audit: /tf.transforms[0] of the turtlesim bag alternates between
    world->turtle1 and world->turtle2 (two broadcasters), nav2_turtlebot's between three
    frames: one channel name for several quantities, silently (and a "drift" found on
    it). Frames of one length or of several (another message layout) alike."""
    messages = [
        ("/tf", TF, T0 + i * MS, tf_message(T0 + i * MS, [("world", children[i % 2], i % 2)]))
        for i in range(300)
    ]
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    got = collect(reader.chunks())
    assert got["/tf.transforms[0].transform.translation.x"][1].size == 300  # (named by index)
    (line,) = reader.info.errors
    assert line.startswith(
        f"/tf: transforms[0].child_frame_id changes between messages ({children[0]}, "
        f"{children[1]}; first at t=0.01 s): /tf.transforms[0].* hold whatever it names"
    )
    assert reader.info.relabelled == ["/tf.transforms[0]."]


def test_two_broadcasters_on_one_topic_are_caught_across_publishers(tmp_path: Path) -> None:
    """Each publisher's own frames never change (two ROS 1 connections, decoded one
    after the other): the topic's frames do."""
    messages = [
        ("/tf", TF, T0 + i * MS, tf_message(T0 + i * MS, [("world", f"t{i % 2}", i % 2)]))
        for i in range(200)
    ]
    path = tmp_path / "two.bag"
    with Ros1Writer(path) as bag:
        conns = [bag.add_connection("/tf", TF, typestore=ROS1, callerid=f"/pub{k}") for k in (0, 1)]
        for i, (_, msgtype, t, make) in enumerate(messages):
            bag.write(conns[i % 2], t, bytes(ROS1.serialize_ros1(make(ROS1), msgtype)))
    reader = open_input(path)
    collect(reader.chunks())
    assert reader.info.relabelled == ["/tf.transforms[0]."]
    assert "transforms[0].child_frame_id changes between messages (t0, t1" in reader.info.errors[0]


def test_frames_that_stay_and_status_texts_say_nothing(tmp_path: Path) -> None:
    """Two transforms whose frames never change, and a diagnostic status whose message
    text changes while its name stays (a text, not what the numbers measure)."""
    messages: list[Message] = [
        ("/tf", TF, T0 + i * MS, tf_message(T0 + i * MS, [("w", "a", i), ("w", "bb", -i)]))
        for i in range(200)
    ]

    def status(i: int) -> Callable[[Any], Any]:
        def make(store: Any) -> Any:
            one = store.types["diagnostic_msgs/msg/DiagnosticStatus"](
                level=i % 3,
                name="motor",
                message=["OK", "warm", "too hot!"][i % 3],
                hardware_id="m1",
                values=[],
            )
            return store.types[DIAG](header=_header(store, T0 + i * MS), status=[one])

        return make

    messages += [("/diagnostics", DIAG, T0 + i * MS + 1, status(i)) for i in range(200)]
    reader = open_input(write(tmp_path / "x.mcap", "mcap", messages))
    got = collect(reader.chunks())
    assert "/tf.transforms[1].transform.translation.x" in got
    assert reader.info.errors == [] and reader.info.relabelled == []


def test_a_run_leaves_a_relabelled_transform_out_unless_named(tmp_path: Path) -> None:
    """The default channels leave /tf.transforms[0].* out (a note names them); named by
    --channels they are analyzed as before."""
    from analyzer.simulate import simulate_building

    t, y, _ = simulate_building(2, 60.0, 100.0, seed=2, sensors_per_floor=2)
    stamps = [T0 + int(round(x * 1e9)) for x in t]
    messages: list[Message] = []
    for i, ns in enumerate(stamps):
        messages += [(f"/s{k}", V3S, ns, v3s(ns, y[i, k])) for k in range(4)]
        messages.append(("/tf", TF, ns + 1, tf_message(ns, [("w", "ab"[i % 2], y[i, i % 2])])))
    path = write(tmp_path / "x.mcap", "mcap", messages)
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--no-progress"]) in (0, 1)
    found = json.loads((out / "findings.json").read_text())
    analyzed = {c for d in found["detectors"] for c in d["channels"]}
    assert analyzed == {f"/s{k}.vector.x" for k in range(4)}
    assert any(n.startswith("not analyzed: /tf.transforms[0].transform") for n in found["notes"])
    # '!' patterns alone leave channels out of the default ones (review: they brought
    # the relabelled ones back, with no note)
    out3 = tmp_path / "o3"
    args = ["run", str(path), "--out", str(out3), "--no-progress", "--channels", "!/s3*"]
    assert main(args) in (0, 1)
    found = json.loads((out3 / "findings.json").read_text())
    assert {c for d in found["detectors"] for c in d["channels"]} == {
        f"/s{k}.vector.x" for k in range(3)
    }
    out2 = tmp_path / "o2"
    args = ["run", str(path), "--out", str(out2), "--no-progress", "--channels", "/s*,/tf*"]
    assert main(args) in (0, 1)
    found = json.loads((out2 / "findings.json").read_text())
    analyzed = {c for d in found["detectors"] for c in d["channels"]}
    assert "/tf.transforms[0].transform.translation.x" in analyzed


@pytest.mark.parametrize("fmt", ["mcap", "ros2"])
def test_a_stub_definition_falls_back_to_the_standard_one(tmp_path: Path, fmt: str) -> None:
    """Real-data audit: rosbag2's sqlite3 'talker' test bag defines rcl_interfaces/msg/Log
    as "uint8 level" (a stub), and the /rosout messages were "not decoded" while the
    standard definition reads them (its MCAP twin was read)."""
    stub = "uint8 x"  # a Vector3Stamped's messages are far longer
    messages = [("/v", V3S, T0 + i * MS, v3s(T0 + i * MS, float(i))) for i in range(50)]
    path = tmp_path / NAMES[fmt]
    if fmt == "mcap":
        with path.open("wb") as handle:
            writer = McapWriter(handle)
            writer.start(profile="ros2", library="test")
            schema = writer.register_schema(V3S, "ros2msg", stub.encode())
            channel = writer.register_channel("/v", "cdr", schema)
            for _, msgtype, t, make in messages:
                data = bytes(ROS2.serialize_cdr(make(ROS2), msgtype))
                writer.add_message(channel, log_time=t, data=data, publish_time=t)
            writer.finish()
    else:
        with Ros2Writer(path, version=9) as bag:
            conn = bag.add_connection("/v", V3S, msgdef=stub, rihs01="RIHS01_" + "0" * 64)
            for _, msgtype, t, make in messages:
                bag.write(conn, t, bytes(ROS2.serialize_cdr(make(ROS2), msgtype)))
    reader = open_input(path)
    got = collect(reader.chunks())
    assert got["/v.vector.x"][1].tolist() == [float(i) for i in range(50)]
    assert reader.info.errors == [
        f"/v: the file's definition of {V3S} does not decode its messages; read with the "
        "standard definition of that type"
    ]


def test_a_ros2_bag_of_mcap_files_marks_a_relabelled_transform(tmp_path: Path) -> None:
    """Review: in a ROS 2 bag stored as MCAP (rosbag2's default since Iron) each storage
    file's reader had a tracker of its own, and the bag's overwrote what it had marked
    (the line said "not analyzed", and the channels were); nor did a frame that changed
    from one split file to the next say anything."""
    for split in (False, True):
        path = tmp_path / f"bag{int(split)}"
        with Ros2Writer(path, version=9, storage_plugin=StoragePlugin.MCAP) as bag:
            conn = bag.add_connection("/tf", TF, typestore=ROS2)
            for i in range(300):
                child = ("a" if i < 150 else "b") if split else "ab"[i % 2]
                message = tf_message(T0 + i * MS, [("world", child, i % 2)])(ROS2)
                bag.write(conn, T0 + i * MS, bytes(ROS2.serialize_cdr(message, TF)))
        if split:  # the second half in a storage file of its own
            _split_mcap_bag(path, 150)
        reader = open_input(path)
        collect(reader.chunks())
        assert reader.info.relabelled == ["/tf.transforms[0]."], split
        (line,) = [e for e in reader.info.errors if "changes between messages" in e]
        assert line.startswith("/tf: transforms[0].child_frame_id changes between messages (a, b")


def _split_mcap_bag(path: Path, at: int) -> None:
    """Rewrite the one-file MCAP bag ``path`` as two storage files split at message
    ``at``, and its metadata.yaml to list both."""
    from mcap.reader import make_reader

    (single,) = sorted(path.glob("*.mcap"))
    with single.open("rb") as handle:
        reader = make_reader(handle)
        summary = reader.get_summary()
        messages = [(c.id, m.log_time, m.data) for _, c, m in reader.iter_messages()]
    (channel,) = summary.channels.values()
    schema = summary.schemas[channel.schema_id]
    names = []
    for k, part in enumerate((messages[:at], messages[at:])):
        name = f"part_{k}.mcap"
        with (path / name).open("wb") as handle:
            writer = McapWriter(handle)
            writer.start(profile="ros2", library="test")
            sid = writer.register_schema(schema.name, schema.encoding, schema.data)
            cid = writer.register_channel(channel.topic, channel.message_encoding, sid)
            for _, t, data in part:
                writer.add_message(cid, log_time=t, data=data, publish_time=t)
            writer.finish()
        names.append(name)
    single.unlink()
    meta = yaml.safe_load((path / "metadata.yaml").read_text())
    info = meta["rosbag2_bagfile_information"]
    info["relative_file_paths"] = names
    info["files"] = [
        {
            "path": n,
            "starting_time": {"nanoseconds_since_epoch": T0},
            "duration": {"nanoseconds": 0},
            "message_count": len(p),
        }
        for n, p in zip(names, (messages[:at], messages[at:]), strict=True)
    ]
    (path / "metadata.yaml").write_text(yaml.safe_dump(meta))


def test_names_that_only_grow_or_shrink_are_no_relabelling(tmp_path: Path) -> None:
    """Review: a JointState whose name[] alternates [a, b, c] / [a, b] keeps each index's
    joint, yet its arrays were left out; its channels are labelled with the longest
    list's names (the robotics audit ux58 item 5)."""
    messages = [
        (
            "/js",
            JS,
            T0 + i * MS,
            joint_state(T0 + i * MS, ["a", "b", "c"][: 2 + i % 2], [i] * (2 + i % 2)),
        )
        for i in range(300)
    ]
    reader = open_input(write(tmp_path / "js.mcap", "mcap", messages))
    collect(reader.chunks())
    assert reader.info.errors == [] and reader.info.relabelled == []
    assert reader.info.labels["/js.position[2]"] == "c"
    assert reader.info.labels["/js.velocity[1]"] == "b"


def test_only_the_first_elements_names_are_compared(tmp_path: Path) -> None:
    """The names of an array of thousands would cost more to compare than the messages
    to read: the first 16 elements' are (transforms[16] on is not marked)."""
    frames = [[("w", f"f{(k + i) % 20}", k) for k in range(20)] for i in range(2)]
    messages = [
        ("/tf", TF, T0 + i * MS, tf_message(T0 + i * MS, frames[i % 2])) for i in range(100)
    ]
    reader = open_input(write(tmp_path / "x.mcap", "mcap", messages))
    collect(reader.chunks())
    assert reader.info.relabelled == [f"/tf.transforms[{k}]." for k in range(16)]
    (line,) = reader.info.errors
    assert "the channels of 16 elements (transforms[0], transforms[1], ...)" in line

"""Quaternions whose sign changes between messages are made continuous before they are
stored (the ux52 audit, item 1: ``ROS_example.bag``'s ground truth flipped from
``orientation.y`` +0.991 to -0.991, q and -q being one rotation, and the run reported
an offset of -1.869 on it; the aligner interpolated across the flip to quaternions far
from unit length).

The logs are written with the real writers (rosbags for ROS 1 and ROS 2 bags, mcap) from
the project's bulk serializer: a pose turning steadily about one axis, written as many
libraries write it, with ``w >= 0``, so that its sign flips each time ``w`` passes 0.
The ROS 1 bag's chunks overlap in time (one chunk spans nearly the whole record and is
read first), as ``ROS_example.bag``'s do: the signs must follow time, not the order the
messages are decoded in."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from mcap.writer import Writer as McapWriter
from readers_helpers import T0, collect
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import StoragePlugin
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_typestore

from analyzer.cli import main
from analyzer.readers import open_input
from analyzer.readers.base import InputInfo
from analyzer.writers import bulk_serialize, default_message

POSE = "geometry_msgs/msg/PoseStamped"
N = 400
FIELDS = ("x", "y", "z", "w")
PREFIX = "/pose.pose.orientation"


def _turning(n: int = N, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Times (100 ms apart, jittered by up to 30 ms, so the aligner interpolates), the
    continuous quaternion of a pose turning two whole turns about a tilted axis (its
    first ``w`` is 1), and the same written with ``w >= 0`` (its sign flips twice)."""
    rng = np.random.default_rng(seed)
    t = T0 + np.arange(n, dtype=np.int64) * 100_000_000
    t += rng.integers(-30_000_000, 30_000_000, n)
    t[0] = T0
    angle = np.linspace(0.0, 4.0 * np.pi, n) + 0.01  # (w never exactly 0)
    axis = np.array([0.0, 0.8, 0.6])
    truth = np.column_stack([np.outer(np.sin(angle / 2), axis), np.cos(angle / 2)])
    written = truth * np.where(truth[:, 3] < 0, -1.0, 1.0)[:, None]
    return t, truth, written


def _rows(encoding: str, t: np.ndarray, q: np.ndarray) -> tuple[object, list[bytes]]:
    store = get_typestore(Stores.ROS2_HUMBLE if encoding == "cdr" else Stores.ROS1_NOETIC)
    header = default_message(store, "std_msgs/msg/Header", frame_id="map")
    template = default_message(store, POSE, header=header)
    columns = {f"pose.orientation.{f}": q[:, j] for j, f in enumerate(FIELDS)}
    columns["pose.position.x"] = np.arange(q.shape[0], dtype=np.float64)
    rows = bulk_serialize(store, POSE, template, columns, encoding=encoding, stamps=t)
    return store, [row.tobytes() for row in rows]


def _ros1(path: Path, t: np.ndarray, q: np.ndarray) -> Path:
    """A ROS 1 bag whose second chunk holds the last message too: it spans nearly the
    whole record and is read before the chunks inside it (``ROS_example.bag``)."""
    store, payloads = _rows("ros1", t, q)
    order = [*range(0, 40), N - 1, *range(40, N - 1)]
    bag = Ros1Writer(path)
    bag.chunk_threshold = 2000
    with bag:
        conn = bag.add_connection("/pose", POSE, typestore=store)
        for i in order:
            bag.write(conn, int(t[i]), payloads[i])
    return path


def _ros2(path: Path, t: np.ndarray, q: np.ndarray) -> Path:
    store, payloads = _rows("cdr", t, q)
    with Ros2Writer(path, version=9, storage_plugin=StoragePlugin.SQLITE3) as writer:
        conn = writer.add_connection("/pose", POSE, typestore=store)
        for i in range(N):
            writer.write(conn, int(t[i]), payloads[i])
    return path


def _mcap(path: Path, t: np.ndarray, q: np.ndarray) -> Path:
    store, payloads = _rows("cdr", t, q)
    text, _ = store.generate_msgdef(POSE, ros_version=2)  # type: ignore[attr-defined]
    with path.open("wb") as handle:
        writer = McapWriter(handle, chunk_size=2000)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(POSE, "ros2msg", text.encode())
        channel = writer.register_channel("/pose", "cdr", schema)
        for i in range(N):
            writer.add_message(channel, int(t[i]), payloads[i], int(t[i]))
        writer.finish()
    return path


WRITERS = {"ros1": (_ros1, "p.bag"), "ros2": (_ros2, "p_bag"), "mcap": (_mcap, "p.mcap")}


@pytest.mark.parametrize("fmt", list(WRITERS))
def test_quaternion_sign_is_continuous_in_every_ros_reader(tmp_path: Path, fmt: str) -> None:
    """Read back, the quaternion is the continuous one (exactly: a negation), the
    position beside it untouched, and the reader says how many sign changes it undid."""
    t, truth, written = _turning()
    assert int(np.count_nonzero(np.sign(written[1:, 3]) != np.sign(truth[1:, 3]))) > 100
    write, name = WRITERS[fmt]
    reader = open_input(write(tmp_path / name, t, written))
    if fmt == "ros1":  # (a chunk from message 40 or before to the last, read early)
        spans = sorted((c.start_ns, c.end_ns) for c in reader._chunk_infos)  # type: ignore[attr-defined]
        assert any(a <= t[40] and b == t[-1] for a, b in spans[:-1]), spans
    got = collect(reader.chunks())
    for j, f in enumerate(FIELDS):
        times, values = got[f"{PREFIX}.{f}"]
        np.testing.assert_array_equal(times, t)
        np.testing.assert_array_equal(values, truth[:, j])
    np.testing.assert_array_equal(got["/pose.pose.position.x"][1], np.arange(N))
    from analyzer.readers.quaternions import Flips  # (new with the signs: imported here,
    # so that the base's reader fails on the values above, not on the import)

    negated = int(np.count_nonzero(truth[:, 3] < 0))
    assert reader.info.sign_flips == {PREFIX: Flips(changes=2, negated=negated, messages=N)}


def test_export_interpolates_between_unit_quaternions(tmp_path: Path) -> None:
    """The aligned rows between two messages across a flip were the mean of q and -q,
    near 0; with the signs continuous every exported quaternion is of unit length (to
    the chord between two neighbours)."""
    t, _, written = _turning()
    bag = _ros1(tmp_path / "p.bag", t, written)
    out = tmp_path / "p.csv"
    assert main(["export", str(bag), "--out", str(out), "--channels", f"{PREFIX}.*"]) == 0
    got = pd.read_csv(out)
    q = got[[f"{PREFIX}.{f}" for f in FIELDS]].dropna().to_numpy()
    assert q.shape[0] > N / 2
    norms = np.linalg.norm(q, axis=1)
    assert norms.min() > 0.999, norms.min()


def test_only_exact_quaternions_and_no_flip_said_when_none(tmp_path: Path) -> None:
    """A JSON (Foxglove-style) MCAP: ``orientation`` (exactly x, y, z, w) is made
    continuous; ``other`` (x, y, z, w and a fifth field) is not a quaternion and keeps
    its values; a quaternion that never changes sign is not in ``sign_flips``."""
    t, truth, written = _turning(60)
    steady = truth.copy()
    steady[:, 3] = np.abs(steady[:, 3]) + 2.0
    steady /= np.linalg.norm(steady, axis=1)[:, None]
    path = tmp_path / "j.mcap"
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="", library="test")
        schema = writer.register_schema("Pose", "jsonschema", b"{}")
        channel = writer.register_channel("/j", "json", schema)
        for i in range(60):
            msg = {
                "orientation": dict(zip(FIELDS, written[i].tolist(), strict=True)),
                "other": {**dict(zip(FIELDS, written[i].tolist(), strict=True)), "t": 1.0},
                "still": dict(zip(FIELDS, steady[i].tolist(), strict=True)),
            }
            writer.add_message(channel, int(t[i]), json.dumps(msg).encode(), int(t[i]))
        writer.finish()
    reader = open_input(path)
    got = collect(reader.chunks())
    for j, f in enumerate(FIELDS):
        np.testing.assert_array_equal(got[f"/j.orientation.{f}"][1], truth[:, j])
        np.testing.assert_array_equal(got[f"/j.other.{f}"][1], written[:, j])
        np.testing.assert_array_equal(got[f"/j.still.{f}"][1], steady[:, j])
    assert list(reader.info.sign_flips) == ["/j.orientation"]


def test_continuous_skips_unusable_rows_and_carries_the_last() -> None:
    """NaN and zero-length quaternions keep their values and do not break the chain; the
    quaternion kept before a batch decides its first row's sign."""
    from analyzer.readers.quaternions import continuous

    q = np.array(
        [
            [0.0, 0.0, 0.0, 1.0],
            [np.nan, 0.0, 0.0, 1.0],
            [0.0, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.1, -0.99],
            [0.0, 0.0, 0.2, -0.98],
        ]
    )
    kept, changes = continuous(q, None)
    assert changes == 1
    np.testing.assert_array_equal(kept[:3], q[:3])
    np.testing.assert_array_equal(kept[3:], -q[3:])
    kept, changes = continuous(q[3:], np.array([0.0, 0.0, 0.0, 1.0]))
    assert changes == 1 and bool((kept[:, 3] > 0).all())
    tail = q[3:]
    kept, changes = continuous(tail, np.array([0.0, 0.0, 0.0, -1.0]))
    assert changes == 0 and kept is tail


def test_note_names_the_analyzed_quaternions_only(tmp_path: Path) -> None:
    """The run's note: how many changes on which channels, for the quaternions of
    which a channel is analyzed; none for the others."""
    from analyzer.readers.quaternions import Flips, flipped_note

    info = InputInfo(tmp_path / "a.bag", "ros1bag")  # type: ignore[arg-type]
    info.sign_flips = {
        "/gt.pose.orientation": Flips(13, 5056, 12765),
        "/slam.pose.orientation": Flips(1, 10, 20),
    }
    note = flipped_note([info], ["/gt.pose.orientation.y", "/gt.pose.position.x"])
    assert "/gt.pose.orientation.{x,y,z,w}: 13 sign changes, 5056 of 12765 messages" in note
    assert "q and -q are the same rotation" in note and "/slam" not in note
    assert flipped_note([info], ["/gt.pose.position.x"]) == ""


@pytest.mark.realdata
def test_ros_example_ground_truth_has_no_sign_jump(corpus: Path) -> None:
    """The audit's bag: every orientation's consecutive quaternions now point the same
    way (the ground truth's dot products went down to -0.99999 at 13 flips)."""
    reader = open_input(corpus / "ros1/evo/ROS_example.bag")
    got = collect(reader.chunks())
    for topic in ("groundtruth", "ORB-SLAM", "S-PTAM"):
        q = np.column_stack([got[f"{topic}.pose.orientation.{f}"][1] for f in FIELDS])
        dots = np.einsum("ij,ij->i", q[1:], q[:-1])
        assert dots.min() > 0.99, (topic, dots.min())
    assert reader.info.sign_flips["groundtruth.pose.orientation"].changes == 13


def test_rotations_of_several_frames_in_turn_are_left_alone(tmp_path: Path) -> None:
    """``/tf.transforms[0]`` holding one frame's rotation, then another's (two
    broadcasters on one topic: its meaning changes between messages, said and not
    analyzed by default) keeps its values as written: no sign can follow one rotation
    there (nav2_turtlebot.mcap's ``/tf.transforms[0]`` had 2 551 "sign changes")."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    tf_type = "tf2_msgs/msg/TFMessage"
    t = T0 + np.arange(60, dtype=np.int64) * 100_000_000
    frames = {"a": (0.0, 0.0, 0.1, 0.995), "b": (0.0, 0.0, -0.1, -0.995)}
    path = tmp_path / "tf.mcap"
    text, _ = store.generate_msgdef(tf_type, ros_version=2)
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(tf_type, "ros2msg", text.encode())
        channel = writer.register_channel("/tf", "cdr", schema)
        for i in range(60):
            child = "a" if i % 2 == 0 else "b"
            x, y, z, w = frames[child]
            transform = default_message(store, "geometry_msgs/msg/TransformStamped")
            transform.header.frame_id = "map"
            transform.child_frame_id = child
            rotation = store.types["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)
            transform.transform.rotation = rotation
            message = store.types[tf_type](transforms=[transform])
            data = bytes(store.serialize_cdr(message, tf_type))
            writer.add_message(channel, int(t[i]), data, int(t[i]))
        writer.finish()
    reader = open_input(path)
    got = collect(reader.chunks())
    prefix = "/tf.transforms[0].transform.rotation"
    w = got[f"{prefix}.w"][1]
    np.testing.assert_array_equal(w, np.where(np.arange(60) % 2 == 0, 0.995, -0.995))
    assert reader.info.relabelled == ["/tf.transforms[0]."]
    assert reader.info.sign_flips == {}

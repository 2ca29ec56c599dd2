"""Real recordings from public repositories (``../shared/realdata``, see its MANIFEST):
counts and values checked against the reference decoders; skipped when absent."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from readers_helpers import collect
from rosbags.highlevel import AnyReader

from analyzer.errors import ReaderError
from analyzer.readers import open_archive, open_input

pytestmark = pytest.mark.realdata


def test_nav2_odometry(corpus: Path) -> None:
    path = corpus / "mcap/evo/nav2_turtlebot.mcap"
    got = collect(open_input(path).chunks())
    times, values = got["/odom.pose.pose.position.x"]
    assert times.size == 2639
    reference = []
    with path.open("rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        for _, _, message, decoded in reader.iter_decoded_messages(topics=["/odom"]):
            reference.append((message.log_time, decoded.pose.pose.position.x))
    np.testing.assert_array_equal(times, [r[0] for r in reference])
    np.testing.assert_array_equal(values, [r[1] for r in reference])
    assert not any(".header." in name for name in got)
    by_header = collect(open_input(path).chunks("header"))["/odom.pose.pose.position.x"][0]
    assert by_header.size == 2639 and not np.array_equal(by_header, times)


def test_turtlesim_bags_in_three_compressions(corpus: Path) -> None:
    base = corpus / "ros1/rosbag.js"
    with AnyReader([base / "example.bag"]) as reader:
        conns = [c for c in reader.connections if c.topic == "/turtle1/pose"]
        reference = [
            (stamp, reader.deserialize(raw, c.msgtype).x)
            for c, stamp, raw in reader.messages(connections=conns)
        ]
    for name in ("example.bag", "example-bz2.bag", "example-lz4.bag"):
        bag = open_input(base / name)
        times, values = collect(bag.chunks())["/turtle1/pose.x"]
        assert times.size == 1344, name
        np.testing.assert_array_equal(times, [r[0] for r in reference])
        np.testing.assert_array_equal(values, [r[1] for r in reference])
        # two broadcasters on /tf: transforms[0] is world->turtle1, then world->turtle2
        (line,) = bag.info.errors
        assert line.startswith(
            "/tf: transforms[0].child_frame_id changes between messages (turtle2, turtle1;"
        )
        assert bag.info.relabelled == ["/tf.transforms[0]."]


def test_nav2_transforms_of_three_frames_are_not_analyzed(corpus: Path, tmp_path: Path) -> None:
    """Real-data audit: /tf.transforms[0] carries odom->base_link, base_link->wheel and
    map->odom in turn; its channels are not analyzed by default (a note says so)."""
    bag = open_input(corpus / "mcap/evo/nav2_turtlebot.mcap")
    collect(bag.chunks())
    assert bag.info.relabelled == ["/tf.transforms[0]."]
    assert any("(odom, map, base_link;" in e for e in bag.info.errors)


def test_ros2_bag_without_embedded_types(corpus: Path) -> None:
    bag = open_input(corpus / "ros2/plotjuggler/rosbag2_test")
    got = collect(bag.chunks())
    assert got["/imu.linear_acceleration.x"][0].size == 1565
    assert got["/pose.pose.position.x"][0].size == 1565
    assert bag.info.errors == []


def test_ros2_storage_variants_agree(corpus: Path) -> None:
    base = corpus / "ros2/rosbag2/rosbag2_tests/resources"
    sqlite = collect(open_input(base / "sqlite3/cdr_test").chunks())
    mcap = collect(open_input(base / "mcap/cdr_test").chunks())
    assert sqlite.keys() == mcap.keys() and "/array_topic.float64_values[2]" in sqlite
    for name in sqlite:
        np.testing.assert_array_equal(sqlite[name][1], mcap[name][1])


@pytest.mark.parametrize(
    ("relative", "match"),
    [
        ("mcap/keelson/2024-05-15_CORRUPT_crlf.mcap", "possibly mangled by a CRLF conversion"),
        ("ros1/rosbag.js/empty-file.bag", r"empty file \(0 bytes\)"),
        (
            "ros2/rosbag2/rosbag2_tests/resources/sqlite3/wrong_rmw_test",
            "unsupported serialization_format 'wrong_format'",
        ),
        (
            "ros2/rosbag2/rosbag2_transport/test/resources/sqlite3/test_bag_for_seek",
            "unknown message type 'test_msgs/msg/BasicTypes' without definitions",
        ),
    ],
)
def test_broken_inputs_raise(corpus: Path, relative: str, match: str) -> None:
    with pytest.raises(ReaderError, match=match):
        open_archive(corpus / relative)


def test_joint_state_bag_with_index_quirk(corpus: Path) -> None:
    bag = open_input(corpus / "ros1/plotjuggler/fake_joint_state.bag")
    got = collect(bag.chunks())
    assert got["/fake_joints_state.position[5]"][0].size == 2725
    assert bag.info.errors == []


def test_data_tamer_records_per_channel_errors(corpus: Path) -> None:
    for path in sorted((corpus / "mcap/data_tamer").glob("*.mcap")):
        reader = open_input(path)
        assert collect(reader.chunks()) == {}
        assert sorted(reader.info.errors) == [
            "channelA: unsupported message encoding 'data_tamer'; skipped",
            "channelB: unsupported message encoding 'data_tamer'; skipped",
        ]


def test_json_and_protobuf_mcaps(corpus: Path) -> None:
    cartpole = collect(open_input(corpus / "mcap/cart-pole/kinda_works.mcap").chunks())
    assert cartpole["/cartpole/state.cart_position"][0].size == 9989
    assert np.count_nonzero(cartpole["/cartpole/state.error"][1] == 2) == 57  # MANIFEST
    log = collect(open_input(corpus / "mcap/coscene/example_protobuf.mcap").chunks())
    assert log["/log.level"][0].size == 9


def test_plotjuggler_csvs(corpus: Path) -> None:
    base = corpus / "csv/plotjuggler"
    simple = collect(open_input(base / "simple.csv").chunks())
    assert {k: v[0].size for k, v in simple.items()} == {"A": 4, "B": 4, "C": 5, "D": 3}
    quoted = open_input(base / "simple_parse_timestamp.csv")
    times = collect(quoted.chunks())["C"][0]
    assert quoted.info.absolute_time and times[0] == 1611137492332000000
    turtle = collect(open_input(base / "turtle.csv").chunks())
    assert turtle["/turtle2/cmd_vel/linear/x"][0].size > 0
    joints = collect(open_input(base / "fake_joints.csv").chunks())
    assert joints["field.position0"][0][0] == 1486559106139796569


def test_skab_semicolon_csv(corpus: Path) -> None:
    reader = open_input(corpus / "benchmark/SKAB/data/valve1/0.csv")
    got = collect(reader.chunks())
    assert got["Accelerometer1RMS"][0].size == 1147
    assert got["Accelerometer1RMS"][1][0] == 0.0265878
    assert reader.info.absolute_time


READABLE_FLOOR = 50
"""Real files that must read (61 of the 76 below read at 4daf9c6, 2026-12-08, 15 refused):
a reader that refused every file cleanly passed this test when each refusal counted."""


def _refused_on_purpose(relative: str, message: str) -> bool:
    """The refusals MANIFEST.md gives a reason for: the CRLF-mangled MCAP and the 0-byte
    bag ("must fail cleanly"), the ``wrong_format`` serialization ("must be rejected or
    skipped"), and old-layout sqlite3 bags of test_msgs types, which carry no
    definitions ("you must supply the definitions yourself")."""
    return (
        relative == "mcap/keelson/2024-05-15_CORRUPT_crlf.mcap"
        or relative == "ros1/rosbag.js/empty-file.bag"
        or "/wrong_rmw_test" in relative
        or ("/sqlite3/" in relative and "unknown message type 'test_msgs/" in message)
    )


def test_every_real_file_reads_or_raises_cleanly(corpus: Path) -> None:
    """No real file may crash a reader: it reads (maybe recording errors) or raises
    ReaderError in one line, for a reason MANIFEST.md gives; at least
    :data:`READABLE_FLOOR` read, and the two files it says must fail do."""
    inputs: list[Path] = []
    for pattern in ("mcap/*/*.mcap", "ros1/*/*.bag", "csv/*/*.csv", "ros2/**/*.db3"):
        inputs += sorted(corpus.glob(pattern))
    inputs += sorted(p.parent for p in corpus.glob("ros2/**/metadata.yaml"))
    assert len(inputs) > 40
    read: list[str] = []
    refused: dict[str, str] = {}
    for path in inputs:
        relative = path.relative_to(corpus).as_posix()
        try:
            archive = open_archive(path)
        except ReaderError as err:
            assert "\n" not in str(err)
            refused[relative] = str(err)
            continue
        collect(archive.chunks())
        collect(archive.chunks("header"))
        read.append(relative)
    assert len(read) >= READABLE_FLOOR, (len(read), refused)
    unexplained = {r: m for r, m in refused.items() if not _refused_on_purpose(r, m)}
    assert not unexplained
    assert {"mcap/keelson/2024-05-15_CORRUPT_crlf.mcap", "ros1/rosbag.js/empty-file.bag"} <= set(
        refused
    )


def test_the_conformance_suites_lfs_pointers_are_named_as_such(corpus: Path) -> None:
    # foxglove/mcap's conformance files are in the corpus as Git LFS pointers only: each
    # is "a Git LFS pointer (to an N-byte file)", N its own recorded size
    pointers = sorted((corpus / "mcap/foxglove_conformance/data").rglob("*.mcap"))
    assert len(pointers) > 100
    for path in pointers[::40]:
        size = next(
            line.split()[1] for line in path.read_text().splitlines() if line.startswith("size ")
        )
        with pytest.raises(ReaderError, match=rf"Git LFS pointer \(to a {size}-byte file\)"):
            open_input(path)


def test_the_sqlite_talkers_stub_definition_falls_back(corpus: Path) -> None:
    """Its message_definitions row for rcl_interfaces/msg/Log is "uint8 level": the
    standard definition reads the 10 /rosout messages, as from its MCAP twin."""
    bag = open_input(corpus / "ros2/rosbag2/rosbag2_py/test/resources/sqlite3/talker")
    got = collect(bag.chunks())
    twin = collect(
        open_input(corpus / "ros2/rosbag2/rosbag2_py/test/resources/mcap/talker").chunks()
    )
    for name in ("/rosout.level", "/rosout.line"):
        np.testing.assert_array_equal(got[name][1], twin[name][1])
    assert got["/rosout.level"][1].size == 10
    assert bag.info.errors == [
        "/rosout: the file's definition of rcl_interfaces/msg/Log does not decode its "
        "messages; read with the standard definition of that type"
    ]

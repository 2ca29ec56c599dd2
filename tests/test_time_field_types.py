"""Times and durations written in ROS messages are told by the fields' types in the
message definition, not by their names (sel52's leftover, ros53): a ``duration``
(``builtin_interfaces/Duration``: a trajectory point's ``time_from_start``) is a span,
not a timestamp (``why`` ``duration field``, left out by default as a plan or a setting,
kept when ``--channels`` names it); a ``time`` is a timestamp whatever it is called; a
``float64`` named ``stamp`` that rises is a measurement (the name rule with "never goes
back" dropped it). The name rule stays for messages whose types the reader does not
know (CSV, JSON, protobuf: tests/test_not_measured.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.rosbag2 import Writer as Ros2Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

from analyzer.cli import main
from analyzer.errors import ArchiveUsageError
from analyzer.readers import open_archive
from analyzer.selection import left_out, select_channels
from analyzer.store import ChannelStore

N = 300
T0 = 1_700_000_000_000_000_000
STEP = 20_000_000  # 50 Hz
RNG = np.random.default_rng(11)
SENSORS = RNG.standard_normal((N, 4))
ODOMETER = np.cumsum(RNG.uniform(0.01, 0.05, N))  # a distance: rises, never goes back
SPANS = RNG.integers(0, 4_000_000_000, (N, 3))  # durations in ns, varying

POINT = "my_pkg/msg/Point"
PLAN = "my_pkg/msg/Plan"
DEFS = {
    POINT: "float64 position\nbuiltin_interfaces/Duration time_from_start\n",
    PLAN: (
        "float64 a\nfloat64 b\nfloat64 stamp\nbuiltin_interfaces/Time taken\n"
        "builtin_interfaces/Duration time_from_start\nmy_pkg/Point[2] points\n"
    ),
}


def _store(kind: Stores):
    store = get_typestore(kind)
    for name, text in DEFS.items():
        store.register(get_types_from_msg(text, name))
    return store


def _messages(store, serialize) -> list[tuple[int, bytes]]:
    """The ``/plan`` messages: two sensors, a rising ``stamp`` (a measurement), the
    message's own time ``taken`` and three durations (one of the message, one of each
    point)."""
    point, plan = store.types[POINT], store.types[PLAN]
    time, span = (
        store.types["builtin_interfaces/msg/Time"],
        store.types["builtin_interfaces/msg/Duration"],
    )
    out = []
    for i in range(N):
        t = T0 + i * STEP
        d = [span(sec=int(s // 10**9), nanosec=int(s % 10**9)) for s in SPANS[i]]
        msg = plan(
            a=float(SENSORS[i, 0]),
            b=float(SENSORS[i, 1]),
            stamp=float(ODOMETER[i]),
            taken=time(sec=t // 10**9, nanosec=t % 10**9),
            time_from_start=d[0],
            points=[
                point(position=float(SENSORS[i, k + 2]), time_from_start=d[k + 1]) for k in (0, 1)
            ],
        )
        out.append((t, bytes(serialize(msg, PLAN))))
    return out


def _ros1(path: Path) -> Path:
    store = _store(Stores.ROS1_NOETIC)
    with Ros1Writer(path) as bag:
        conn = bag.add_connection("/plan", PLAN, typestore=store)
        for t, data in _messages(store, store.serialize_ros1):
            bag.write(conn, t, data)
    return path


def _ros2(path: Path) -> Path:
    store = _store(Stores.ROS2_HUMBLE)
    with Ros2Writer(path, version=9) as bag:
        conn = bag.add_connection("/plan", PLAN, typestore=store)
        for t, data in _messages(store, store.serialize_cdr):
            bag.write(conn, t, data)
    return path


def _mcap(path: Path) -> Path:
    store = _store(Stores.ROS2_HUMBLE)
    text, _ = store.generate_msgdef(PLAN, ros_version=2)  # type: ignore[attr-defined]
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="ros2", library="test")
        schema = writer.register_schema(PLAN, "ros2msg", text.encode())
        channel = writer.register_channel("/plan", "cdr", schema)
        for t, data in _messages(store, store.serialize_cdr):
            writer.add_message(channel, t, data, t)
        writer.finish()
    return path


MAKERS = pytest.mark.parametrize("make", [_ros1, _ros2, _mcap], ids=["ros1", "ros2", "mcap"])

DURATIONS = (
    "/plan.time_from_start.sec",
    "/plan.time_from_start.nanosec",
    "/plan.points[0].time_from_start.sec",
    "/plan.points[1].time_from_start.nanosec",
)


@MAKERS
def test_the_field_types_say_time_duration_or_measurement(tmp_path, capsys, make):
    assert main(["inspect", str(make(tmp_path / "rec.bag")), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    whys = {c["name"]: c.get("why") for c in report["channels"]}
    assert whys["/plan.taken.sec"] == "timestamp field"
    assert whys["/plan.taken.nanosec"] == "timestamp field"
    for name in DURATIONS:
        assert whys[name] == "duration field", (name, whys)
    # (a float64 named stamp that rises is a reading: the name rule dropped it)
    for name in ("/plan.a", "/plan.b", "/plan.stamp", "/plan.points[0].position"):
        assert whys[name] is None, (name, whys)
    assert report["run_defaults"]["channels"] == 5


def test_inspect_text_explains_the_duration_mark(tmp_path, capsys):
    assert main(["inspect", str(_ros1(tmp_path / "rec.bag"))]) == 0
    out = capsys.readouterr().out
    assert "/plan.time_from_start.sec [duration field]" in out
    assert "[duration field] a span of time written in the message" in out


def test_the_note_names_durations_apart_and_channels_keeps_them(tmp_path):
    from analyzer.selection import typed_fields  # (new: the other tests run on the base)

    archive = open_archive([_mcap(tmp_path / "rec.mcap")])
    store = ChannelStore.from_chunks(archive.chunks("log"))
    typed = typed_fields(archive.inputs)  # (known once the messages are read)
    with store:
        notes: list[str] = []
        chosen = select_channels(store, None, notes, typed=typed)
        assert "/plan.stamp" in chosen and "/plan.time_from_start.sec" not in chosen
        said = [n for n in notes if "not measurements" in n]
        assert len(said) == 1, notes
        assert "timestamps: /plan.taken.sec, /plan.taken.nanosec" in said[0]
        assert "durations (a plan or a setting, not a reading): " in said[0]
        why = left_out(notes, {i.name: i for i in store.infos()})
        assert why["/plan.points[1].time_from_start.sec"] == {"why": "duration field"}
        named = select_channels(store, ["/plan.time_from_start.*", "/plan.a"], [], typed=typed)
        assert named == ["/plan.a", "/plan.time_from_start.sec", "/plan.time_from_start.nanosec"]


def test_time_fields_walks_arrays_and_skips_the_header():
    from analyzer.readers.rosdecode import time_fields

    store = _store(Stores.ROS1_NOETIC)
    assert time_fields(store, PLAN) == {
        "taken.sec": "time",
        "taken.nanosec": "time",
        "time_from_start.sec": "duration",
        "time_from_start.nanosec": "duration",
        "points[*].time_from_start.sec": "duration",
        "points[*].time_from_start.nanosec": "duration",
    }
    # (a header's stamp is the message's time, never a channel)
    assert time_fields(store, "geometry_msgs/msg/PoseStamped") == {}


def test_a_record_of_durations_only_is_refused_naming_what_it_holds(tmp_path):
    archive = open_archive([_ros1(tmp_path / "rec.bag")])
    store = ChannelStore.from_chunks(archive.chunks("log"))
    typed = {t: f for i in archive.inputs for t, f in i.time_fields.items()}
    others = ["!/plan.a", "!/plan.b", "!/plan.stamp", "!/plan.points*position", "!/plan.taken.*"]
    with store, pytest.raises(ArchiveUsageError) as err:
        select_channels(store, others, [], typed=typed)
    line = str(err.value)
    assert "every varying channel is a duration, not a measurement" in line, line
    assert "timestamp" not in line and "log message" not in line

"""An MCAP, a ROS 1 bag or a ROS 2 bag whose recorder's own clock (its log times, not the header
stamps) is set during the recording. Set back by hours (an RTC that ran ahead, then
NTP): the messages logged after it have log times before those written before them; the
reader reads in log-time order, so they were sorted in before the earlier ones, silently
(``--time log``), or seemed a header clock gone back and were dropped (``--time
header``). Now the input says it (``inspect``, exit 0) and ``run`` and ``export`` refuse
it (exit 2), as a CSV's time column set back. Set forward: a gap with ``--time log``, as
a pause of the recorder, and nothing with ``--time header``, whose stamps go on. Files
made with the real writers (``mcap``, ``rosbags``); a ROS 2 bag's sqlite3 file and an
MCAP's loose (unchunked) messages checked since ff22576."""

from __future__ import annotations

import html
import json
from pathlib import Path

import numpy as np
import pytest
from mcap.writer import IndexType
from readers_helpers import T0, collect
from test_readers_probe30 import MS, V3S, Message, v3s, write, write_mcap

from analyzer.cli import main
from analyzer.readers import mcap_reader, open_input, ros2_reader
from analyzer.readers._common import LogClock, stamp_text

HOUR = 3600 * 10**9
N, AT = 3000, 2000


def _recorded(jump: int, at: int = AT, count: int = N - AT) -> list[Message]:
    """``/imu`` and ``/odom`` at 100 Hz, stamped on a clock that goes on; the recorder's
    clock moves by ``jump`` at message ``at`` for ``count`` messages; in the order
    written."""
    rng = np.random.default_rng(1)
    out: list[Message] = []
    for i in range(N):
        stamp = T0 + i * MS
        log = stamp + 2_000_000 + (jump if at <= i < at + count else 0)
        out.append(("/imu", V3S, log, v3s(stamp, np.sin(i / 50) + 0.01 * rng.normal())))
        out.append(("/odom", V3S, log + MS // 4, v3s(stamp, rng.normal())))
    return out


def _small_chunks(path: Path, messages: list[Message], indexed: bool = True) -> Path:
    """``messages`` in an MCAP of ~4 kB chunks: the step falls between chunks. Not
    ``indexed``: without message indexes nor chunk indexes (read as a stream, in the
    file's order)."""
    kinds = IndexType.ALL if indexed else IndexType.NONE
    return write_mcap(path, messages, chunk_size=4000, index_types=kinds)


KINDS = ["mcap", "mcap chunks", "mcap stream", "mcap loose", "ros1", "ros2", "ros2 mcap"]
"""How a recording is written (:func:`_written`)."""


def _written(
    folder: Path, name: str, kind: str, messages: list[Message], monkeypatch: pytest.MonkeyPatch
) -> Path:
    """``messages`` as ``kind``: an MCAP in one chunk, in small chunks (indexed or as a
    stream), or unchunked (``loose``); a ROS 1 bag; a ROS 2 bag, sqlite3 or MCAP
    storage. Loose messages and sqlite3 rows read 1500 at a time: a step at message
    2000 of each topic (row 4000) falls inside the third batch, the fourth set back
    against those before."""
    monkeypatch.setattr(mcap_reader, "LOOSE_BATCH", 1500)
    monkeypatch.setattr(ros2_reader, "SQL_BATCH", 1500)
    if kind in ("mcap chunks", "mcap stream"):
        return _small_chunks(folder / f"{name}.mcap", messages, indexed=kind == "mcap chunks")
    if kind == "mcap loose":
        return write_mcap(folder / f"{name}.mcap", messages, use_chunking=False)
    if kind == "ros2 mcap":
        return write(folder / f"{name}_bag", "ros2 mcap", messages)
    suffix = {"mcap": ".mcap", "ros1": ".bag"}.get(kind, "")
    return write(folder / f"{name}{suffix}", kind, messages)


SAID = (
    "the log times step back by 2.0 h: {where} 2025-12-31T22:00:20.002Z, after messages "
    "logged up to 2026-01-01T00:00:19.992Z (the recorder's clock set back during the "
    "recording?); its messages cannot be placed among those logged before them (they "
    "would be sorted in among them): split the recording there"
)


@pytest.mark.parametrize("time", ["log", "header"])
@pytest.mark.parametrize("kind", KINDS)
def test_a_recorder_clock_set_back_is_said_and_refused(
    tmp_path: Path,
    time: str,
    kind: str,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Set back by 2 h at message 2000 of 3000: at 580dd8d the last 1000 messages were
    placed 2 h before the first (``--time log``, said nowhere) or dropped as a header
    clock gone back (``--time header``); ``run`` and ``export`` went on. In one chunk
    (the messages of a topic compared) or across chunks (each topic's messages against
    its own in the chunks written before); also in a ROS 1 bag. At ff22576, also an
    MCAP's loose messages (each batch against those before) and a ROS 2 bag's sqlite3
    file (its rows in the order written)."""
    path = _written(tmp_path, "x", kind, _recorded(-2 * HOUR), monkeypatch)
    chunked = kind in ("mcap chunks", "mcap stream")
    reader = open_input(path)
    collect(reader.chunks(time))  # type: ignore[arg-type]
    said = reader.info.set_back
    if chunked:
        # (the chunks of each topic compared, the first topic of the chunk set back named)
        assert said.split(": a message logged at 2025-12-31T22:00:20.00")[0] in (
            "the log times step back by 2.0 h: /imu",
            "the log times step back by 2.0 h: /odom",
        )
        assert said.endswith(SAID.split("2026-01-01T00:00:19.992Z")[1])
    else:
        assert said == SAID.format(where="/imu: a message logged at")
    # (with --time header, not also the header clock's step and jump back the set back
    # made, "header.stamp jumps 2.0 h back ... use --time log": misleading. Loose
    # messages are read a batch at a time in the file's order, each batch in log-time
    # order: the one the set back falls in shows its stamps going back, said after it)
    extra = reader.info.errors[1:] if kind == "mcap loose" and time == "header" else []
    assert all("header.stamp goes back by" in line for line in extra)
    assert reader.info.errors == [said, *extra] and reader.info.clock_steps == {}
    assert main(["inspect", str(path), "--time", time]) == 0
    assert f"  ! {said}\n" in capsys.readouterr().out
    for command in (
        ["run", str(path), "--out", str(tmp_path / "o"), "--time", time, "--no-progress"],
        ["export", str(path), "--out", str(tmp_path / "o.csv"), "--time", time],
    ):
        assert main(command) == 2
        assert capsys.readouterr().err == f"analyzer: error: {path}: {said}\n"


def test_a_few_messages_logged_far_back_are_no_clock_set_back(tmp_path: Path) -> None:
    """Up to 4 messages of a topic logged 2 h back (a recorder's clock read wrong): the
    reorderer's business, as before; nothing refused."""
    reader = open_input(write(tmp_path / "x.mcap", "mcap", _recorded(-2 * HOUR, count=4)))
    collect(reader.chunks())
    assert not any("log times step back" in e for e in reader.info.errors)


@pytest.mark.parametrize("kind", ["mcap", "mcap loose", "ros2"])
@pytest.mark.parametrize("jump", [HOUR, 10 * 60 * 10**9])
def test_a_recorder_clock_set_forward_is_a_gap_or_nothing(
    tmp_path: Path, jump: int, kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Set forward by an hour or 10 minutes at message 2000, the stamps going on: with
    ``--time log`` a gap of that length, as a pause of the recorder (both clocks moved
    forward together); with ``--time header`` the stamps analyzed as they are, no step
    of the header clock named (its stamps did not jump: only the log times did)."""
    path = _written(tmp_path, "x", kind, _recorded(jump), monkeypatch)
    reader = open_input(path)
    t, _ = collect(reader.chunks())["/imu.vector.x"]
    assert reader.info.errors == []
    assert int(np.diff(t).max()) == jump + MS
    reader = open_input(path)
    t, _ = collect(reader.chunks("header"))["/imu.vector.x"]
    assert reader.info.clock_steps == {} and reader.info.errors == []
    assert t.size == N and int(np.diff(t).max()) == MS


@pytest.mark.parametrize("kind", ["mcap", "mcap loose", "ros1", "ros2"])
def test_a_recorder_clock_set_back_under_an_hour_is_sorted_in_as_before(
    tmp_path: Path, kind: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Set back by 50 minutes at message 2000 (under :data:`LOG_SET_BACK_NS`): not
    said, nothing refused; with ``--time log`` its messages sorted in among the earlier
    ones, every one kept, as before."""
    path = _written(tmp_path, "x", kind, _recorded(-50 * 60 * 10**9), monkeypatch)
    reader = open_input(path)
    t, _ = collect(reader.chunks())["/imu.vector.x"]
    assert reader.info.set_back == "" and reader.info.errors == []
    assert t.size == N and int(t[0]) == T0 + AT * MS + 2_000_000 - 50 * 60 * 10**9


def _topic_by_topic(path: Path, kind: str) -> Path:
    """``/imu``'s whole recording (0 to 2 h at 1 Hz), then ``/odom``'s, in ~4 kB chunks:
    each topic's chunks in log-time order, the file's not (a converter writing topic by
    topic, or a bag connection by connection): valid, read as at 580dd8d."""
    messages: list[Message] = []
    for topic in ("/imu", "/odom"):
        for i in range(7200):
            t = T0 + i * 10**9
            messages.append((topic, V3S, t, v3s(t, float(np.sin(i / 50)))))
    if kind.startswith("mcap"):
        return _small_chunks(path, messages, indexed=kind == "mcap")
    if kind == "ros2":
        return write(path, "ros2", messages)
    from rosbags.rosbag1 import Writer as Ros1Writer
    from test_readers_probe30 import ROS1

    with Ros1Writer(path) as bag:
        bag.chunk_threshold = 4000
        conns = {t: bag.add_connection(t, V3S, typestore=ROS1) for t in ("/imu", "/odom")}
        for topic, msgtype, t, make in messages:
            bag.write(conns[topic], t, bytes(ROS1.serialize_ros1(make(ROS1), msgtype)))
    return path


@pytest.mark.parametrize("kind", ["mcap", "mcap stream", "ros1", "ros2"])
def test_a_file_written_topic_by_topic_is_no_clock_set_back(
    tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Its chunks of ``/odom`` start 2 h before the end of ``/imu``'s written before
    them; each topic's log times go on: read and analyzed whole (on the first version of
    the check, comparing the chunks whatever their topics, refused)."""
    name = {"ros1": "x.bag", "ros2": "x"}.get(kind, "x.mcap")
    path = _topic_by_topic(tmp_path / name, kind)
    reader = open_input(path)
    got = collect(reader.chunks())
    assert reader.info.errors == []
    assert {name: t.size for name, (t, _) in got.items() if name.endswith(".x")} == {
        "/imu.vector.x": 7200,
        "/odom.vector.x": 7200,
    }
    code = main(["export", str(path), "--out", str(tmp_path / "o.csv")])
    assert code == 0, capsys.readouterr().err


def _shifted(messages: list[Message], by: int) -> list[Message]:
    return [(topic, msgtype, t + by, make) for topic, msgtype, t, make in messages]


@pytest.mark.parametrize("kind", ["mcap", "mcap chunks", "mcap loose", "ros1", "ros2"])
def test_a_set_back_file_of_a_folder_is_left_out_and_said(
    tmp_path: Path, kind: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A folder of three recordings, the middle one's recorder clock set back by 2 h:
    the contract's damaged file of a multi-file archive. ``run`` analyzes the two others
    (exit 0 or 1), the middle one not analyzed, its line under ``inputs[].errors`` and
    in the report; ``inspect`` lists it (exit 0). (On the first version of the check,
    the whole folder was refused, exit 2. At ff22576, an MCAP of loose messages and a
    ROS 2 bag's sqlite3 file were analyzed whole, the set back sorted in.)"""
    folder = tmp_path / "f"
    folder.mkdir()
    paths = [
        _written(folder, str(k), kind, _shifted(_recorded(jump), k * 40 * 10**9), monkeypatch)
        for k, jump in enumerate((0, -2 * HOUR, 0))
    ]
    code = main(["run", str(folder), "--out", str(tmp_path / "o"), "--no-progress"])
    capsys.readouterr()
    assert code in (0, 1)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    errors = {i["path"]: i["errors"] for i in doc["inputs"]}
    stopped = f"reading stopped: {paths[1]}: the log times step back by 2.0 h: "
    assert [e.startswith(stopped) for e in errors[str(paths[1])]] == [True]
    assert errors[str(paths[0])] == errors[str(paths[2])] == []
    samples = {c["name"]: c["samples"] for c in doc["channels"]}
    assert samples["/imu.vector.x"] == 2 * N  # (the two others, whole)
    report = html.unescape((tmp_path / "o" / "report.html").read_text())
    assert errors[str(paths[1])][0] in report
    assert main(["inspect", str(folder)]) == 0
    assert f"  ! {errors[str(paths[1])][0]}\n" in capsys.readouterr().out


def test_a_set_back_inside_a_chunk_is_said_after_the_newest_before_it() -> None:
    """The chunk the set back falls in starts with messages logged after those of the
    chunk before: the line says the newest before the set back (at ff22576, the newest
    of the chunks before)."""
    clock = LogClock(in_file_order=True)
    log = T0 + np.arange(1000) * MS
    log[750:] -= 2 * HOUR
    clock.messages("/imu", np.arange(500), log[:500])
    clock.messages("/imu", np.arange(500), log[500:])
    newest = f"after messages logged up to {stamp_text(int(log[749]))} ("
    assert clock.back_ns == int(log[749] - log[750]) and newest in clock.line

"""An input with nothing numeric in it (an MCAP or bag of strings, a bag without messages,
a CSV whose columns are all text) is readable: ``inspect`` lists it (exit 0) with a note
in its text and ``--json`` output and a warning on stderr that nothing in it can be
analyzed (it said nothing, or, for the CSV, refused it); ``run`` and ``export`` refuse
it in one line naming the file (exit 2). Logs are built with the real writers."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from cli_helpers import one_line_error, run_cli
from mcap.writer import Writer as McapWriter
from rosbags.rosbag1 import Writer as Ros1Writer
from rosbags.typesys import Stores, get_typestore

ROS2 = get_typestore(Stores.ROS2_HUMBLE)
STRING = "std_msgs/msg/String"
T0 = 1_767_225_600_000_000_000  # 2026-01-01T00:00:00Z


def _strings_mcap(path: Path) -> Path:
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="ros2", library="test")
        text = ROS2.generate_msgdef(STRING, ros_version=2)[0]
        schema = writer.register_schema(STRING, "ros2msg", text.encode())
        channel = writer.register_channel("/chatter", "cdr", schema)
        for i in range(50):
            message = ROS2.types[STRING](data=f"hello {i}")
            data = bytes(ROS2.serialize_cdr(message, STRING))
            t = T0 + i * 10_000_000
            writer.add_message(channel, log_time=t, data=data, publish_time=t)
        writer.finish()
    return path


def _empty_bag(path: Path) -> Path:
    with Ros1Writer(path):
        pass
    return path


def _text_csv(path: Path) -> Path:
    path.write_text("time,label,state\n0.0,a,ok\n0.1,b,ok\n0.2,c,bad\n")
    return path


INPUTS = {"strings.mcap": _strings_mcap, "empty.bag": _empty_bag, "labels.csv": _text_csv}


@pytest.mark.parametrize("name", list(INPUTS))
def test_inspect_says_nothing_can_be_analyzed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    path = INPUTS[name](tmp_path / name)
    code, out, err = run_cli(["inspect", "--json", path], capsys)
    assert code == 0
    doc = json.loads(out)
    assert doc["channels"] == [] and doc["inputs"][0]["errors"] == []
    (note,) = doc["notes"]
    assert note.startswith(f"nothing to analyze: {path} holds no numeric channel (")
    assert note.endswith("); run and export refuse it")
    if name == "labels.csv":
        assert "(no numeric column besides the time column 'time' (text: label, state))" in note
    assert err == f"analyzer: warning: {note}\n"
    # run_defaults is there as for any archive run refuses (before, it was missing)
    refused = doc["run_defaults"]["refused"]
    assert doc["run_defaults"] == {"channels": 0, "refused": refused}
    assert refused.startswith(f"{path}: no numeric channel found")
    code, out, err = run_cli(["inspect", path], capsys)
    assert code == 0
    assert f"note: {note}" in out.splitlines()
    lines = out.rstrip().splitlines()
    assert lines[-2].endswith("0 channel(s)")
    assert lines[-1] == f"run refuses this archive by default: {refused}"
    assert err == f"analyzer: warning: {note}\n"


@pytest.mark.parametrize("name", list(INPUTS))
def test_run_and_export_refuse_it_naming_the_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    path = INPUTS[name](tmp_path / name)
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    line = one_line_error(err, f"{path}: no numeric channel found")
    code, out, _ = run_cli(["inspect", "--json", path], capsys)
    assert line == f"analyzer: error: {json.loads(out)['run_defaults']['refused']}"
    code, _, err = run_cli(["export", path, "--out", tmp_path / "o.csv"], capsys)
    assert code == 2
    line = one_line_error(err, f"{path}: no numeric channel to export")
    if name == "labels.csv":
        assert line.endswith(
            "(no numeric column besides the time column 'time' (text: label, state))"
        )
    assert not (tmp_path / "o.csv").exists()


def test_an_undecodable_input_is_still_an_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Where the reading itself failed (an encoding no decoder reads), ``inspect``'s
    error line says why, as before: that is not "read, and nothing numeric"."""
    path = tmp_path / "custom.mcap"
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="", library="test")
        schema = writer.register_schema("T", "custom", b"x")
        channel = writer.register_channel("/c", "custom", schema)
        writer.add_message(channel, log_time=T0, data=b"\x01", publish_time=T0)
        writer.finish()
    code, out, err = run_cli(["inspect", "--json", path], capsys)
    assert code == 2 and out == ""
    one_line_error(err, "unsupported message encoding 'custom'")


@pytest.mark.realdata
@pytest.mark.parametrize(
    "name", ["ros1/rosbag.js/example-unsorted-chunks.bag", "ros1/rosbag.js/no-messages.bag"]
)
def test_real_inputs_with_nothing_numeric(
    realdata: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], name: str
) -> None:
    """The corpus's string-only bag (``foo``, std_msgs/String) and its bag without
    messages: exit 0 with nothing said before."""
    path = realdata / name
    code, out, err = run_cli(["inspect", "--json", path], capsys)
    assert code == 0
    (note,) = json.loads(out)["notes"]
    assert note.startswith(f"nothing to analyze: {path} holds no numeric channel")
    assert err == f"analyzer: warning: {note}\n"
    code, _, err = run_cli(["run", path, "--out", tmp_path / "o", "--no-progress"], capsys)
    assert code == 2
    line = one_line_error(err, f"{path}: no numeric channel found")
    code, out, _ = run_cli(["inspect", "--json", path], capsys)
    assert line == f"analyzer: error: {json.loads(out)['run_defaults']['refused']}"

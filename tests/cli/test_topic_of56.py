"""A channel's topic by one rule that knows the record's topics (a maintainer's audit,
ux61 item H1): a CSV column is its own, dots and all (``acc.x`` is no field of a topic
``acc``), and an MCAP topic whose name holds a dot (``imu.front``) is named whole. The
base split every name at its first dot: a CSV of ``acc.x, gyro.x`` read "acc: no sample
... while gyro went on", names that are nowhere in the file."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from cli_helpers import run_cli, run_to, said
from mcap.writer import Writer as McapWriter

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

T0 = 1_780_000_000_000_000_000
"""The recordings' first time (ns since 1970: 2026-05-28)."""


def _signals(seconds: float = 120.0) -> tuple[np.ndarray, np.ndarray]:
    """Four floors of a building sampled at 200 Hz: times (s) and values."""
    t, y, _ = simulate_building(n_floors=4, duration_s=seconds, seed=2)
    return t, y


def test_topic_of_takes_the_longest_known_topic_or_the_name_itself():
    from analyzer.readers.base import topic_of  # (new: not on the base)

    ros = {"/imu/data", "/odom"}
    assert topic_of("/imu/data.linear_acceleration.y", ros) == "/imu/data"
    assert topic_of("/odom.pose.pose.position.x", ros) == "/odom"
    dotted = {"imu", "imu.front"}  # (an MCAP's topics: one is another's prefix)
    assert topic_of("imu.front.x", dotted) == "imu.front"
    assert topic_of("imu.rear.x", dotted) == "imu"
    assert topic_of("arr[3]", {"arr"}) == "arr"
    assert topic_of("acc.x", ()) == "acc.x"  # (a CSV: no topics)
    assert topic_of("accel.x", {"acc"}) == "accel.x"  # (a prefix of the name, not a topic's)


def test_a_dotted_csv_column_is_named_whole_in_the_silence_note(tmp_path, capsys):
    t, y = _signals()
    names = ["acc.x", "acc.y", "gyro.x", "gyro.y"]
    y[(t >= 50.0) & (t < 55.0), :2] = np.nan  # acc.* blank: no sample
    path = tmp_path / "dotted.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, j] for j, n in enumerate(names)})
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code in (0, 1), err
    (line,) = [ln for ln in said(err) if "silent mid-record" in ln]
    assert "acc.x, acc.y: no sample from 49.995 to 55.000 s" in line, line
    assert "while gyro.x, gyro.y went on" in line, line
    assert any("acc.x, acc.y: no sample from 49.995" in n for n in doc["notes"])


def _dotted_mcap(path: Path) -> Path:
    """A JSON MCAP as Foxglove may write one, with topics ``imu.front`` and ``imu.rear``
    (fields ``x``, ``y``) at 200 Hz for 120 s; ``imu.front`` publishes nothing from 50 to
    55 s."""
    t, y = _signals()
    t_ns = T0 + np.round(t * 1e9).astype(np.int64)
    with path.open("wb") as handle:
        writer = McapWriter(handle)
        writer.start(profile="", library="test")
        ids = {}
        for topic in ("imu.front", "imu.rear"):
            schema = writer.register_schema(f"{topic}.Imu", "jsonschema", b"{}")
            ids[topic] = writer.register_channel(topic, "json", schema)
        silent = (t >= 50.0) & (t < 55.0)
        for k in range(t.size):
            for j, topic in enumerate(("imu.front", "imu.rear")):
                if j == 0 and silent[k]:
                    continue
                row = {"x": float(y[k, 2 * j]), "y": float(y[k, 2 * j + 1])}
                stamp = int(t_ns[k])
                writer.add_message(ids[topic], stamp, json.dumps(row).encode(), stamp)
        writer.finish()
    return path


def test_an_mcap_topic_with_a_dot_is_named_whole(tmp_path, capsys):
    path = _dotted_mcap(tmp_path / "dotted.mcap")
    code, out, err = run_cli(["inspect", path, "--json"], capsys)
    assert code == 0, err
    listed = json.loads(out)
    assert {c["name"] for c in listed["channels"]} == {
        "imu.front.x",
        "imu.front.y",
        "imu.rear.x",
        "imu.rear.y",
    }
    # (both topics gave channels: none is listed as a topic of text)
    assert "topics_without_numbers" not in listed, listed.get("topics_without_numbers")
    code, err, doc, _ = run_to(tmp_path, capsys, path, "--jobs", "1")
    assert code in (0, 1), err
    (line,) = [ln for ln in said(err) if "silent mid-record" in ln]
    assert "imu.front: no sample from 49.995 to 55.000 s" in line, line
    assert "while imu.rear went on" in line, line

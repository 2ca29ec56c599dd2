"""A ``JointState``'s arrays are named by index (the contract: ``position[i]``); where its
``name[]`` does not change between messages, each element is labelled with its joint
(``InputInfo.labels``), shown beside the channel in ``inspect``, findings.json
(``channels[].label``, ``faults[].label``), the run's last line and the report (ux58 #5:
``/joint_states.velocity[4] multiplicative`` never said it was ``right_wheel``). A name
order that changes between messages is put back in the first order by name (rob56), and
labelled so."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect
from test_readers_probe30 import JS, MS, NAMES, _joint_messages, joint_state, write

from analyzer.cli import main
from analyzer.readers import open_input
from analyzer.readers.base import channel_label, channel_labels


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_steady_joint_names_label_their_elements(tmp_path: Path, fmt: str) -> None:
    messages = [
        ("/js", JS, T0 + i * MS, joint_state(T0 + i * MS, ["arm", "wheel"], [i, -i]))
        for i in range(300)
    ]
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    collect(reader.chunks())
    assert reader.info.labels == {
        "/js.position[0]": "arm",
        "/js.position[1]": "wheel",
        "/js.velocity[0]": "arm",
        "/js.velocity[1]": "wheel",
    }
    assert reader.info.errors == []


def test_a_changing_name_order_labels_the_first_order(tmp_path: Path) -> None:
    """[a, b, c] then [b, a, c]: the values are put back in the first order by name
    (rob56 #2), so each index keeps its joint and is labelled with it."""
    reader = open_input(write(tmp_path / "x.mcap", "mcap", _joint_messages()))
    collect(reader.chunks())
    assert reader.info.relabelled == []
    assert reader.info.labels["/joint_states.position[0]"] == "a"
    assert reader.info.labels["/joint_states.velocity[2]"] == "c"


def test_an_element_label_covers_its_channels() -> None:
    labels = {"/tf.transforms[0]": "base_link", "/js.position[1]": "b"}
    assert channel_label(labels, "/tf.transforms[0].transform.translation.x") == "base_link"
    assert channel_label(labels, "/tf.transforms[1].transform.translation.x") is None
    assert channel_label(labels, "/js.position[1]") == "b"
    assert channel_label(labels, "/js.position[10]") is None


def _gain_on_b(tmp_path: Path) -> Path:
    """60 s of a 3-joint JointState at 100 Hz: one shared motion plus noise on each joint,
    the joint ``b`` (index 1) read 1.6 times too large from 40 s."""
    rng = np.random.default_rng(2)
    n = 6000
    t = np.arange(n) / 100.0
    motion = np.sin(2 * np.pi * 0.7 * t) + 0.5 * np.sin(2 * np.pi * 1.9 * t)
    pos = np.stack([(1 + k / 3) * motion + 0.05 * rng.standard_normal(n) for k in range(3)], axis=1)
    pos[t >= 40.0, 1] *= 1.6
    messages = [
        ("/js", JS, T0 + i * MS, joint_state(T0 + i * MS, ["a", "b", "c"], pos[i]))
        for i in range(n)
    ]
    return write(tmp_path / "js.mcap", "mcap", messages)


def test_the_joint_is_named_beside_its_channel(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = _gain_on_b(tmp_path)
    assert main(["inspect", str(path), "--json"]) == 0
    doc = json.loads(capsys.readouterr().out)
    labels = {c["name"]: c.get("label") for c in doc["channels"]}
    assert labels["/js.position[1]"] == "b" and labels["/js.velocity[2]"] == "c"
    assert main(["inspect", str(path)]) == 0
    assert "/js.position[1] (b)" in capsys.readouterr().out
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--jobs", "1"]) == 1
    err = capsys.readouterr().err
    assert "/js.position[1] (b) multiplicative" in err.splitlines()[-1]
    findings = json.loads((out / "findings.json").read_text())
    assert [(f["channel"], f.get("label")) for f in findings["faults"]] == [
        ("/js.position[1]", "b")
    ]
    assert "/js.position[1] (b)" in (out / "report.html").read_text()
    inputs = open_input(path)
    collect(inputs.chunks())
    assert channel_labels([inputs.info], ["/js.position[0]", "/other"]) == {"/js.position[0]": "a"}

"""A ``JointState`` whose ``name[]`` order changes mid-record (a driver restarted publishes
the same joints in another order: rob56 #2). The channels are by index (the contract:
``/joint_states.position[4]``); after the change index 4 was another joint, so one
channel mixed two joints (and, said as a relabelling, the joint channels were left out
of a default run). The values are now put back in the first-seen order by name (per
distinct order of a batch, not per message), with a line naming the topic and the time;
a joint that appears or goes missing is said."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from readers_helpers import T0, collect
from test_readers_probe30 import JS, MS, NAMES, joint_state, write

from analyzer.cli import main
from analyzer.readers import open_input

JOINTS = ["shoulder", "elbow", "wrist", "gripper", "wheel"]
RESTART = ["wheel", "gripper", "shoulder", "elbow", "wrist"]
N = 900


def _truth(n: int = N) -> np.ndarray:
    """Each joint's position by name: joint k reads k * 100 + the message's index."""
    return np.arange(n)[:, None] + 100.0 * np.arange(len(JOINTS))[None, :]


def _restart(at: int, order: list[str] = RESTART) -> list:
    truth = _truth()
    out = []
    for i in range(N):
        names = JOINTS if i < at else order
        pos = [truth[i, JOINTS.index(n)] for n in names]
        out.append(("/joint_states", JS, T0 + i * MS, joint_state(T0 + i * MS, names, pos)))
    return out


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_a_restarted_driver_s_order_is_put_back_by_name(tmp_path: Path, fmt: str) -> None:
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, _restart(300)))
    got = collect(reader.chunks())
    truth = _truth()
    for k, joint in enumerate(JOINTS):
        np.testing.assert_array_equal(got[f"/joint_states.position[{k}]"][1], truth[:, k])
        np.testing.assert_allclose(got[f"/joint_states.velocity[{k}]"][1], 0.1 * truth[:, k])
        assert reader.info.labels[f"/joint_states.velocity[{k}]"] == joint
    assert reader.info.relabelled == []
    assert reader.info.errors == [
        "/joint_states: name[] changed order at t=3.00 s ([shoulder, elbow, wrist, gripper, "
        "wheel] -> [wheel, gripper, shoulder, elbow, wrist]); position[i], velocity[i] put "
        "back in the first order by name, [shoulder, elbow, wrist, gripper, wheel]"
    ]


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_a_joint_that_appears_or_goes_missing_is_said(tmp_path: Path, fmt: str) -> None:
    """After the restart ``elbow`` is gone and ``tool`` is new: ``tool`` gets the next
    index (5), ``elbow``'s channel has no sample from there."""
    order = ["wheel", "tool", "gripper", "shoulder", "wrist"]
    truth = _truth()
    messages = []
    for i in range(N):
        names = JOINTS if i < 450 else order
        pos = [truth[i, JOINTS.index(n)] if n in JOINTS else -1.0 - i for n in names]
        messages.append(("/js", JS, T0 + i * MS, joint_state(T0 + i * MS, names, pos)))
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    got = collect(reader.chunks())
    np.testing.assert_array_equal(got["/js.position[0]"][1], truth[:, 0])
    np.testing.assert_array_equal(got["/js.position[1]"][1], truth[:450, 1])  # (elbow)
    np.testing.assert_array_equal(got["/js.position[4]"][1], truth[:, 4])
    np.testing.assert_array_equal(got["/js.position[5]"][1], -1.0 - np.arange(450, N))
    assert reader.info.labels["/js.position[5]"] == "tool"
    (line,) = reader.info.errors
    assert line.startswith("/js: name[] changed order at t=4.50 s")
    assert line.endswith("; added: tool from t=4.50 s; missing: elbow from t=4.50 s")


def test_the_values_move_per_order_not_per_message() -> None:
    """:func:`by_name`: rows 1 and 3 have the order [b, a]; row 2 has no names (another
    layout): its values stay."""
    from analyzer.readers._common import by_name

    columns = {
        "position[0]": (None, np.array([1.0, 2.0, 3.0, 4.0])),
        "position[1]": (None, np.array([10.0, 20.0, 30.0, 40.0])),
        "other": (None, np.zeros(4)),
    }
    rows = np.array([0, 1, 3])
    codes = np.array([0, 1, 1])
    out = by_name(columns, ("position",), 4, rows, codes, [[0, 1], [1, 0]])
    assert list(out) == ["position[0]", "position[1]", "other"]
    np.testing.assert_array_equal(out["position[0]"][1], [1.0, 20.0, 3.0, 40.0])
    np.testing.assert_array_equal(out["position[1]"][1], [10.0, 2.0, 30.0, 4.0])
    assert out["position[0]"][0] is None


def test_a_run_audits_the_joints_and_finds_the_real_fault(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """60 s of a 3-joint arm at 100 Hz, the driver restarted at 20 s publishing [c, a, b],
    the joint ``b`` read 1.6 times too large from 40 s: one finding, on ``b``'s channel.
    On 49eb6ce the joint channels were left out (index 0 held two joints)."""
    rng = np.random.default_rng(2)
    n = 6000
    t = np.arange(n) / 100.0
    motion = np.sin(2 * np.pi * 0.7 * t) + 0.5 * np.sin(2 * np.pi * 1.9 * t)
    pos = np.stack([(1 + k / 3) * motion + 0.05 * rng.standard_normal(n) for k in range(3)], axis=1)
    pos[t >= 40.0, 1] *= 1.6
    messages = []
    for i in range(n):
        names = ["a", "b", "c"] if t[i] < 20.0 else ["c", "a", "b"]
        values = [pos[i, "abc".index(x)] for x in names]
        messages.append(("/js", JS, T0 + i * MS, joint_state(T0 + i * MS, names, values)))
    path = write(tmp_path / "js.mcap", "mcap", messages)
    out = tmp_path / "o"
    assert main(["run", str(path), "--out", str(out), "--jobs", "1"]) == 1
    err = capsys.readouterr().err
    assert "name[] changed order at t=20.00 s" in err
    findings = json.loads((out / "findings.json").read_text())
    assert [(f["channel"], f.get("label"), f["type"]) for f in findings["faults"]] == [
        ("/js.position[1]", "b", "multiplicative")
    ]


def test_repeated_names_are_no_order_to_follow(tmp_path: Path) -> None:
    """[a, a, b] then [b, a, a]: which ``a`` is which cannot be told; left out as
    before (the index line)."""
    messages = [
        (
            "/js",
            JS,
            T0 + i * MS,
            joint_state(T0 + i * MS, ["a", "a", "b"] if i < 50 else ["b", "a", "a"], [i, -i, 0]),
        )
        for i in range(100)
    ]
    reader = open_input(write(tmp_path / "x.mcap", "mcap", messages))
    collect(reader.chunks())
    assert reader.info.relabelled == ["/js.position[", "/js.velocity["]
    (line,) = reader.info.errors
    assert "follow the index, not the name" in line

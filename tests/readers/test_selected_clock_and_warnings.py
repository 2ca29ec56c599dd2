"""``export``'s default clock and the input warnings of ``run`` and ``export`` follow the
channels chosen (a new user's audit, ux52 items 8 and 13): nav2's ``/tf.transforms[0].*``
(three frames interleaved: "meaning changes", which ``run`` leaves out) set ``export``'s
clock at 58.2 Hz against ``run``'s 27.6 Hz; ``run --time header --channels '/odom.*'``
still warned of two clocks (telling the user to do what they had done), and every
``export --channels '/imu_data.*'`` warned about ``/tf``, which it did not export."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from readers_helpers import T0
from test_readers_probe30 import MS, NAMES, TF, V3S, Message, _header, write

from analyzer.cli import main
from analyzer.readers.base import InputInfo
from analyzer.types import Format

V3 = "geometry_msgs/msg/Vector3"
SIM0 = 924 * 10**9


def _stamped(stamp_ns: int, x: float, y: float, z: float) -> Any:
    def make(store: Any) -> Any:
        vector = store.types[V3](x=float(x), y=float(y), z=float(z))
        return store.types[V3S](header=_header(store, stamp_ns), vector=vector)

    return make


def _transform(stamp_ns: int, child: str, xyz: np.ndarray) -> Any:
    def make(store: Any) -> Any:
        header = _header(store, stamp_ns)
        header.frame_id = "world"
        tr = store.types[V3](x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2]))
        rot = store.types["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0)
        transform = store.types["geometry_msgs/msg/Transform"](translation=tr, rotation=rot)
        stamped = store.types["geometry_msgs/msg/TransformStamped"](
            header=header, child_frame_id=child, transform=transform
        )
        return store.types[TF](transforms=[stamped])

    return make


def _tf_beside_odometry(n: int = 400) -> list[Message]:
    """``/odom`` (3 varying channels) at 25 Hz beside ``/tf`` at 100 Hz whose one
    transform alternates between two frames (4 varying channels, meaning changes)."""
    rng = np.random.default_rng(5)
    out: list[Message] = []
    for i in range(n):
        t = T0 + i * MS
        child = "odom" if i % 2 else "base_link"
        out.append(("/tf", TF, t, _transform(t, child, rng.normal(size=3) + 5 * (i % 2))))
        if i % 4 == 0:
            out.append(("/odom", V3S, t + 1, _stamped(t, *rng.normal(size=3))))
    return out


def _exported(path: Path, tmp_path: Path, capsys, *options: str) -> tuple[str, str]:
    """``export``'s stderr: its warnings and its last line."""
    out = tmp_path / "e.csv"
    assert main(["export", str(path), "--out", str(out), *options]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    return "\n".join(err[:-1]), err[-1]


@pytest.mark.parametrize("fmt", ["mcap", "ros1"])
def test_export_runs_at_the_clock_of_the_channels_run_analyzes(tmp_path, capsys, fmt):
    path = write(tmp_path / NAMES[fmt], fmt, _tf_beside_odometry())
    warnings, last = _exported(path, tmp_path, capsys)
    assert " at 25 Hz " in last, last
    assert "/tf: transforms[0].child_frame_id changes between messages" in warnings
    # (the transforms alone set it where they are all that is exported)
    _, last = _exported(path, tmp_path, capsys, "--channels", "/tf.*")
    assert " at 100 Hz " in last, last
    # (--rate is --rate)
    _, last = _exported(path, tmp_path, capsys, "--rate", "50")
    assert " at 50 Hz " in last, last


def test_export_says_nothing_of_a_topic_it_does_not_export(tmp_path, capsys):
    path = write(tmp_path / "x.mcap", "mcap", _tf_beside_odometry())
    warnings, last = _exported(path, tmp_path, capsys, "--channels", "/odom.*")
    assert "rows of 3 channels at 25 Hz" in last, last
    assert "/tf" not in warnings, warnings
    warnings, _ = _exported(path, tmp_path, capsys, "--channels", "/odom.*,/tf.*")
    assert "/tf: transforms[0].child_frame_id changes between messages" in warnings


def _two_clocks(n: int = 3000) -> list[Message]:
    """``/odom`` (3 varying channels) stamped on a simulation clock, ``/tf`` without a
    header (its log times, on the wall clock): both logged at 100 Hz."""
    rng = np.random.default_rng(3)
    x = np.zeros((n, 3))
    for i in range(1, n):  # (a slow AR(1) each: something to model)
        x[i] = 0.9 * x[i - 1] + rng.normal(size=3)
    out: list[Message] = []
    for i in range(n):
        out.append(("/odom", V3S, T0 + i * MS, _stamped(SIM0 + i * MS, *x[i])))
        out.append(("/tf", V3, T0 + i * MS + MS // 2, _vector(rng.normal())))
    return out


def _vector(v: float) -> Any:
    def make(store: Any) -> Any:
        return store.types[V3](x=float(v), y=0.0, z=0.0)

    return make


def test_run_of_one_clocks_topics_does_not_repeat_the_two_clocks_line(tmp_path, capsys):
    path = write(tmp_path / "x.mcap", "mcap", _two_clocks())
    args = ["run", str(path), "--time", "header", "--no-progress", "--train", "0:20"]
    code = main([*args, "--out", str(tmp_path / "o"), "--channels", "/odom.*"])
    err = capsys.readouterr().err
    assert code in (0, 1), err
    assert "two clocks" not in err, err
    # (where both clocks are chosen, it is refused naming them, as before)
    code = main([*args, "--out", str(tmp_path / "o2"), "--channels", "/odom.*,/tf.*"])
    err = capsys.readouterr().err
    assert code == 2 and "two clocks" in err


def test_about_selection_reads_topic_lines_and_the_two_clocks_line():
    from analyzer.readers.base import about_selection

    info = InputInfo(Path("x.mcap"), Format.MCAP)
    info.clocks = {"/odom": "header", "/amcl_pose": "header", "/tf": "log"}
    channels = ["/odom.x", "/odom.y", "/amcl_pose.x", "/tf.transforms[0].x", "/tf.x"]
    two = "--time header: two clocks: /odom, /amcl_pose timed by their header.stamp (...)"
    assert not about_selection(two, info, channels, ["/odom.x", "/amcl_pose.x"])
    assert about_selection(two, info, channels, ["/odom.x", "/tf.x"])
    tf = "/tf: 16 messages repeat the timestamp of the one before"
    assert not about_selection(tf, info, channels, ["/odom.x"])
    assert about_selection(tf, info, channels, ["/odom.x", "/tf.transforms[0].x"])
    # (a line that names no topic of the archive is said whatever is chosen)
    cut = "truncated at byte 300000 (unexpected end of file)"
    assert about_selection(cut, info, channels, ["/odom.x"])

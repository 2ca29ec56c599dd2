"""``--time header`` where some topics carry header stamps on a simulation clock and the
others no header (their log times, on the wall clock): the realdata audit's
``nav2_turtlebot.mcap`` (``/odom``, ``/amcl_pose`` stamped from ~924 s, ``/tf``,
``/tf_static`` TFMessages without a top-level header) was refused with "a timestamp lies
far from the others (an outlier, or a wrong unit)". The reader now says which topics run
on which clock, and ``run`` and ``export`` name that as the reason, with what to do.
Logs are built with the real writers (mcap, rosbags)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from readers_helpers import T0, collect
from test_readers_probe30 import MS, NAMES, V3S, Message, v3s, write

from analyzer.cli import main
from analyzer.readers import open_input

V3 = "geometry_msgs/msg/Vector3"
SIM0 = 924 * 10**9  # the simulation clock's time when the recording starts


def _vector(x: float) -> Any:
    def make(store: Any) -> Any:
        return store.types[V3](x=float(x), y=0.0, z=0.0)

    return make


def _mixed(n: int = 600, sim0: int = SIM0) -> list[Message]:
    """``/odom`` stamped on the simulation clock (``sim0`` on), ``/tf`` without a header:
    both logged at 100 Hz on the wall clock."""
    rng = np.random.default_rng(3)
    out: list[Message] = []
    for i in range(n):
        out.append(("/odom", V3S, T0 + i * MS, v3s(sim0 + i * MS, rng.normal())))
        out.append(("/tf", V3, T0 + i * MS + MS // 2, _vector(rng.normal())))
    return out


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_reader_names_the_two_clocks(tmp_path: Path, fmt: str) -> None:
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, _mixed()))
    got = collect(reader.chunks("header"))
    assert got["/odom.vector.x"][0][0] == SIM0 and got["/tf.x"][0][0] > 10**18
    assert reader.info.clocks == {"/odom": "header", "/tf": "log"}
    (line,) = [e for e in reader.info.errors if e.startswith("--time header")]
    assert "/odom timed by their header.stamp (924.000 to 929.990 s, not Unix times" in line
    assert "/tf by their log times (no header.stamp, or 0; Unix times, 2026-" in line
    assert "use --time log, or --channels to choose topics of one clock" in line


def test_log_time_and_one_clock_say_nothing(tmp_path: Path) -> None:
    """With log times, or where the header stamps are Unix times too, nothing is said."""
    path = write(tmp_path / "x.mcap", "mcap", _mixed())
    reader = open_input(path)
    collect(reader.chunks("log"))
    assert reader.info.clocks == {} and reader.info.errors == []
    reader = open_input(write(tmp_path / "wall.mcap", "mcap", _mixed(sim0=T0 - 50 * MS)))
    collect(reader.chunks("header"))
    assert reader.info.clocks == {} and reader.info.errors == []


def _refused(path: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> list[str]:
    """The one-line errors of ``run`` and ``export`` of all of ``path`` with ``--time
    header`` (exit 2), which no longer blame an outlier."""
    errors = []
    for command in (
        ["run", path, "--out", tmp_path / "o", "--time", "header", "--no-progress"],
        ["export", path, "--out", tmp_path / "o.csv", "--time", "header"],
    ):
        assert main([str(a) for a in command]) == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and "Traceback" not in err
        assert "far from the others" not in err
        errors.append(err)
    return errors


def test_run_and_export_name_the_clocks_not_an_outlier(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write(tmp_path / "x.mcap", "mcap", _mixed())
    for err in _refused(path, tmp_path, capsys):
        assert f"analyzer: error: {path}: --time header: two clocks: /odom timed by" in err
    # the topics of one clock: no refusal for it
    out = tmp_path / "odom.csv"
    command = ["export", path, "--out", out, "--time", "header", "--channels", "/odom.*"]
    assert main([str(a) for a in command]) == 0
    header = out.read_text().splitlines()[0].replace('"', "")
    assert header == "time,/odom.vector.x,/odom.vector.y,/odom.vector.z"
    assert main(["export", str(path), "--out", str(tmp_path / "log.csv")]) == 0


@pytest.mark.realdata
def test_nav2_turtlebot_header_clocks(
    corpus: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The real file: ``/odom`` and ``/amcl_pose`` stamped on the simulation clock,
    ``/tf`` and ``/tf_static`` by their log times."""
    path = corpus / "mcap/evo/nav2_turtlebot.mcap"
    command = ["run", str(path), "--out", str(tmp_path / "o"), "--time", "header"]
    assert main([*command, "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert (
        "--time header: two clocks: /odom, /amcl_pose timed by their header.stamp "
        "(924.102 to 1025.496 s, not Unix times: a simulation clock?), /tf by their log "
        "times" in err
    )
    assert "far from the others" not in err


# ------------------------------------------------- two Unix clocks far apart (contract46)

YEARS5 = 5 * 365 * 86400 * 10**9  # a robot clock never synchronised since 2021 (1825 days)
HOUR = 3600 * 10**9


def _unix_apart(n: int = 600, imu_off: int = -YEARS5) -> list[Message]:
    """``/imu`` stamped ``imu_off`` from its log times, ``/odom`` stamped at its log
    times, ``/tf`` without a header: all logged at 100 Hz by the recorder."""
    rng = np.random.default_rng(5)
    out: list[Message] = []
    for i in range(n):
        t = T0 + i * MS
        out.append(("/imu", V3S, t, v3s(t + imu_off, rng.normal())))
        out.append(("/odom", V3S, t + MS // 4, v3s(t, rng.normal())))
        out.append(("/tf", V3, t + MS // 2, _vector(rng.normal())))
    return out


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_header_stamps_years_before_the_log_times_are_two_clocks(tmp_path: Path, fmt: str) -> None:
    """Every topic with a header stamped by an unsynchronised clock in 2021, the topic
    without one at the recorder's 2026 log times: both Unix times, five years apart."""
    messages = _mixed(sim0=T0 - YEARS5)
    reader = open_input(write(tmp_path / NAMES[fmt], fmt, messages))
    collect(reader.chunks("header"))
    assert reader.info.clocks == {"/odom": "header", "/tf": "log"}
    (line,) = [e for e in reader.info.errors if e.startswith("--time header")]
    assert "/odom timed by their header.stamp (Unix times, 2021-01-02T" in line
    assert "1825 days before the others), /tf by their log times (no header.stamp" in line
    assert "or 0; Unix times, 2026-01-01T00:00:00.005Z to 2026-01-01T00:00:05.995Z)" in line


@pytest.mark.parametrize("fmt", ["mcap", "ros2"])
def test_one_topic_stamped_years_off_is_the_clock_apart(
    tmp_path: Path, fmt: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """``/imu`` years off beside ``/odom`` stamped on the recorder's clock and ``/tf``
    at its log times: ``inspect`` says so (exit 0), ``run`` and ``export`` of channels
    of both clocks are refused naming them (exit 2), of one clock they pass."""
    path = write(tmp_path / NAMES[fmt], fmt, _unix_apart())
    reader = open_input(path)
    collect(reader.chunks("header"))
    assert reader.info.clocks == {"/imu": "header", "/odom": "stamped", "/tf": "log"}
    assert main(["inspect", str(path), "--time", "header"]) == 0
    out = capsys.readouterr().out
    assert (
        "two clocks: /imu timed by their header.stamp (Unix times, 2021-01-02T00:00:00.000Z "
        "to 2021-01-02T00:00:05.990Z, 1825 days before the others), /odom by their "
        "header.stamp and /tf by their log times (no header.stamp, or 0; together Unix "
        "times, 2026-01-01T00:00:00.000Z to 2026-01-01T00:00:05.995Z)" in out
    )
    for err in _refused(path, tmp_path, capsys):
        assert f"analyzer: error: {path}: --time header: two clocks: /imu timed by" in err
        assert "use --time log, or --channels to choose topics of one clock" in err
    for chosen in ("/odom.*,/tf.*", "/imu.*"):
        command = ["export", path, "--out", tmp_path / "one.csv", "--time", "header"]
        assert main([str(a) for a in [*command, "--channels", chosen]]) == 0
        capsys.readouterr()


@pytest.mark.parametrize(
    "offset, recording",
    [
        (-HOUR // 2, 0),  # half an hour off: further than the recording lasts, within the hour
        (-2 * HOUR, 3 * HOUR),  # two hours off, in a recording of three
    ],
)
def test_header_stamps_near_enough_are_one_clock(
    tmp_path: Path, offset: int, recording: int
) -> None:
    """Stamps off by less than an hour, or by less than the recording lasts: one clock
    (late or latched messages, a clock a little off), nothing said."""
    messages = _unix_apart(imu_off=offset)
    if recording:  # a topic without header logged at the start and at the recording's end
        messages += [("/beacon", V3, T0 + t, _vector(1.0)) for t in (0, recording)]
    reader = open_input(write(tmp_path / "x.mcap", "mcap", messages))
    collect(reader.chunks("header"))
    assert reader.info.clocks == {} and reader.info.errors == []

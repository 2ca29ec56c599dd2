"""``--time header`` where one topic's header clock is set during the recording: a robot
clock that ran on its own (from 1970 plus the uptime, or a day off) and was set by NTP
or PTP at message N, so that the topic's stamps jump by years or hours there while its
log times go on. The topic's span covers the jump, so the two-clock rule (which compares
the topics' spans) did not apply and ``run`` said "a timestamp lies far from the others";
a clock set back by a day dropped every message after it and said the same. Now the
reader names the topic, the message, the times on both sides and what to do; ``run`` and
``export`` of its channels stop with that line (exit 2). A pause of the recorder (both
times jump), a smaller step and a stamp or two off stay as they were. Also a CSV's time
column set back by more than an hour. Logs are built with the real writers."""

from __future__ import annotations

import html
import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from readers_helpers import T0, collect
from test_readers_probe30 import MS, NAMES, V3S, Message, v3s, write, write_mcap
from test_two_clocks import _refused

from analyzer.cli import main
from analyzer.readers import csv_reader, open_input
from analyzer.readers._common import Decoded, Reorderer, TopicTracker

V3 = "geometry_msgs/msg/Vector3"
HOUR = 3600 * 10**9
DAY = 24 * HOUR
UPTIME = 1000 * 10**9  # the robot clock before NTP: 1970 plus the time since boot


def _vector(x: float) -> Any:
    def make(store: Any) -> Any:
        return store.types[V3](x=float(x), y=0.0, z=0.0)

    return make


def _stepped(
    stamp: Any, n: int = 800, at: int = 300, pause: int = 0, odom: Any = None
) -> list[Message]:
    """``/imu`` stamped ``stamp(i, t)`` for message ``i`` logged at ``t`` (its header
    clock), ``/odom`` stamped ``odom(i, t)`` (default: at its log times), ``/tf`` without
    a header: all logged at 100 Hz; with ``pause``, the recorder stops for that long
    before message ``at`` (log times and every clock move on together)."""
    rng = np.random.default_rng(7)
    odom = odom or (lambda i, t: t)
    out: list[Message] = []
    for i in range(n):
        t = T0 + i * MS + (pause if i >= at else 0)
        out.append(("/imu", V3S, t, v3s(stamp(i, t), rng.normal())))
        out.append(("/odom", V3S, t + MS // 4, v3s(odom(i, t), rng.normal())))
        out.append(("/tf", V3, t + MS // 2, _vector(rng.normal())))
    return out


def synced_from_uptime(i: int, t: int) -> int:
    """Stamps from 1970 plus the uptime until NTP sets the clock at message 300."""
    return UPTIME + i * MS if i < 300 else t


def set_back_a_day(i: int, t: int) -> int:
    """A clock a day ahead, set back at message 300."""
    return t + DAY if i < 300 else t


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
@pytest.mark.parametrize(
    "stamp, said",
    [
        (
            synced_from_uptime,
            "header.stamp jumps 20454 days forward at message 300 (t=3.00 s), from "
            "1002.990 s (not a Unix time) to 2026-01-01T00:00:03.000Z, while its log "
            "times go on (a clock set during the recording?)",
        ),
        (
            set_back_a_day,
            "header.stamp jumps 24 h back at message 300 (t=3.00 s), from "
            "2026-01-02T00:00:02.990Z to 2026-01-01T00:00:03.000Z, while its log times go "
            "on (a clock set during the recording?)",
        ),
    ],
)
def test_a_header_clock_set_during_the_recording_is_named(
    tmp_path: Path, fmt: str, stamp: Any, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """``inspect`` says it (exit 0); ``run`` and ``export`` stop on it (exit 2, one
    line: before, "a timestamp lies far from the others")."""
    path = write(tmp_path / NAMES[fmt], fmt, _stepped(stamp))
    reader = open_input(path)
    collect(reader.chunks("header"))
    assert reader.info.clock_steps == {"/imu": said}
    assert reader.info.clocks == {}
    assert f"/imu: {said}; use --time log, or leave it out with --channels '!/imu.*'" in (
        reader.info.errors
    )
    assert main(["inspect", str(path), "--time", "header"]) == 0
    assert said in capsys.readouterr().out
    for err in _refused(path, tmp_path, capsys):
        assert err == (
            f"analyzer: error: {path}: --time header: /imu: {said}; one analysis needs one "
            "clock: use --time log, or leave it out with --channels '!/imu.*'\n"
        )


def test_the_remedies_pass(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """The topic left out, or the log times: the export goes through, and says nothing
    (the line on the topic left out is in ``inspect``'s errors; repeated on stderr
    after the user followed it, it read as unheeded: ux52 item 13)."""
    path = write(tmp_path / "x.mcap", "mcap", _stepped(synced_from_uptime))
    for extra, warned in (
        (["--time", "header", "--channels", "!/imu.*"], False),
        (["--time", "log"], False),
    ):
        command = ["export", str(path), "--out", str(tmp_path / "o.csv"), *extra]
        assert main(command) == 0
        assert ("warning" in capsys.readouterr().err) == warned
    header = (tmp_path / "o.csv").read_text().splitlines()[0]
    assert "/imu.vector.x" in header


def test_every_topic_set_at_once_names_the_first_and_the_others(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The robot's clock set for all its topics: each topic said; the refusal names the
    first to jump and the others, and leaves them all out."""
    messages = _stepped(synced_from_uptime, odom=synced_from_uptime)
    path = write(tmp_path / "x.mcap", "mcap", messages)
    reader = open_input(path)
    collect(reader.chunks("header"))
    assert list(reader.info.clock_steps) == ["/imu", "/odom"]
    (err,) = _refused(path, tmp_path, capsys)[:1]
    assert "--time header: /imu: header.stamp jumps 20454 days forward" in err
    assert err.endswith(
        "(a clock set during the recording?) (also /odom); one analysis needs one clock: "
        "use --time log, or leave them out with --channels '!/imu.*,!/odom.*'\n"
    )


def test_a_step_across_batches_is_the_same_step(tmp_path: Path) -> None:
    """Small MCAP chunks (batches of a few messages): the stretches are carried from
    batch to batch, and the step is found once, at the same message."""
    path = tmp_path / "small_chunks.mcap"
    write_mcap(path, _stepped(set_back_a_day), chunk_size=1500)
    reader = open_input(path)
    collect(reader.chunks("header"))
    (said,) = reader.info.clock_steps.values()
    assert said.startswith("header.stamp jumps 24 h back at message 300 (t=3.00 s)")
    assert "such jumps" not in said


def test_a_clock_set_early_or_at_the_end_is_a_step(tmp_path: Path) -> None:
    """Set 0.05 s into the recording (5 messages on the old clock), or 0.05 s before its
    end: still a step (more than :data:`LEAD_GLITCH_MESSAGES` messages at an edge)."""
    for at in (5, 795):
        messages = _stepped(lambda i, t, at=at: t - DAY if i < at else t, at=at)
        reader = open_input(write(tmp_path / f"{at}.mcap", "mcap", messages))
        collect(reader.chunks("header"))
        (said,) = reader.info.clock_steps.values()
        assert said.startswith(f"header.stamp jumps 24 h forward at message {at} ")


def _decoded(stamps: np.ndarray) -> Decoded:
    x = np.arange(stamps.size, dtype=np.float64)
    return Decoded(int(stamps.size), {"x": (None, x)}, stamps.astype(np.int64))


@pytest.mark.parametrize("batch", [1, 2, 3, 5, 7, 64, 300, 1000])
def test_the_step_is_the_same_in_batches_of_any_size(batch: int) -> None:
    """The tracker alone, the same 1000 messages in batches of 1 to 1000: glitches of a
    few messages 10 years back at 100-102, just before the step (495-496) and just after
    it (600-601), and the step (a day forward) at 500: one step, from message 499 to 500,
    however they are cut."""
    i = np.arange(1000)
    log = T0 + i * MS
    stamps = np.where(i < 500, log - DAY, log)
    stamps[100:103] -= 3650 * DAY
    stamps[495:497] -= 3650 * DAY
    stamps[600:602] -= 3650 * DAY
    tracker = TopicTracker("header")
    for a in range(0, i.size, batch):
        part = slice(a, a + batch)
        tracker.push(Reorderer(repeats=True), "/b", _decoded(stamps[part]), log[part])
    assert tracker.clock_steps() == {
        "/b": "header.stamp jumps 24 h forward at message 500 (t=5.00 s), from "
        "2025-12-31T00:00:04.990Z to 2026-01-01T00:00:05.000Z, while its log times go on "
        "(a clock set during the recording?)"
    }


def _said(tmp_path: Path, messages: list[Message]) -> list[str]:
    """What the reader says of ``messages`` with ``--time header``: no step (these
    tests pass on the code before the rule too)."""
    reader = open_input(write(tmp_path / "x.mcap", "mcap", messages))
    collect(reader.chunks("header"))
    assert not getattr(reader.info, "clock_steps", {})
    assert not any("jumps" in e for e in reader.info.errors)
    return reader.info.errors


def test_a_pause_of_the_recorder_is_no_step(tmp_path: Path) -> None:
    """The recorder stops for two hours: header stamps and log times jump together (the
    offset stays): nothing said, as before."""
    assert _said(tmp_path, _stepped(lambda i, t: t, pause=2 * HOUR)) == []


MINUTE = 60 * 10**9


@pytest.mark.parametrize(
    "moved, said",
    [
        (10 * MINUTE, "jumps 10 min forward"),
        (-10 * MINUTE, "jumps 10 min back"),
        (30 * 10**9, "jumps 30 s forward"),
        (-30 * 10**9, "jumps 30 s back"),
        (-50 * MINUTE, "jumps 50 min back"),
    ],
)
def test_a_wall_clock_step_under_the_hour_is_named(
    tmp_path: Path, moved: int, said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """A header clock of Unix times set by 10 minutes or 30 s at message 300 while its
    log times go on: named and refused as a step of hours is (at 580dd8d, whose floor
    was an hour, the topic was analyzed shifted by the step after it, or its messages
    dropped behind the newest stamp, with no step said)."""
    path = write(tmp_path / "x.mcap", "mcap", _stepped(lambda i, t: t if i < 300 else t + moved))
    reader = open_input(path)
    collect(reader.chunks("header"))
    assert list(reader.info.clock_steps) == ["/imu"]
    assert reader.info.clock_steps["/imu"].startswith(f"header.stamp {said} at message 300 ")
    for err in _refused(path, tmp_path, capsys):
        assert f"--time header: /imu: header.stamp {said} at message 300 " in err


def _jittered(i: int, t: int) -> int:
    """Stamps from a few hundred ms before the log time (a latency that wanders: a
    loaded recorder, an estimate stamped with the time of its data) to 1.9 s before it
    from message 400 on (a stretch of 4 s, then back)."""
    wander = int(np.random.default_rng(i).uniform(0, 400_000_000))
    return t - wander - (1_500_000_000 if 400 <= i < 800 else 0)


def test_jitter_and_pauses_are_no_step(tmp_path: Path) -> None:
    """What moves the offset from stamp to log without a clock set: a wandering latency
    (up to 1.9 s), a recorder that pauses 10 minutes (both times move), a source that
    pauses 10 minutes (a playback paused: the log times move, the stamps go on), and
    messages queued through a 30-s outage that arrive in a burst (the last 15 s of
    stamps, logged together, then as before)."""
    assert _said(tmp_path, _stepped(_jittered, n=1200)) == []
    assert _said(tmp_path, _stepped(lambda i, t: t, pause=10 * MINUTE)) == []
    paused = _stepped(lambda i, t: t - (10 * MINUTE if i >= 300 else 0), pause=10 * MINUTE)
    assert _said(tmp_path, paused) == []
    burst: list[Message] = []
    rng = np.random.default_rng(5)
    for i in range(3600):
        stamp = T0 + i * MS
        if 300 <= i < 1800:
            continue  # (a 30-s outage: the queue keeps the last 1500 messages, 15 s)
        # the queued messages arrive together at the outage's end, then as before
        log = T0 + 3300 * MS + (i - 1800) * 10**4 if 1800 <= i < 3300 else stamp + MS // 2
        burst.append(("/imu", V3S, log, v3s(stamp, rng.normal())))
        burst.append(("/odom", V3S, stamp + MS // 4, v3s(stamp, rng.normal())))
    _said(tmp_path, sorted(burst, key=lambda m: m[2]))  # (no step; the glitch rule may drop one)


def test_a_simulation_clock_keeps_the_hour(tmp_path: Path) -> None:
    """Header stamps on a simulation clock (from 1000 s, not Unix times) beside the
    recorder's wall clock: a simulation paused or run slower moves them against the log
    times by any amount, so its step is an hour, as before: 10 minutes are not named."""
    reader = open_input(
        write(
            tmp_path / "x.mcap",
            "mcap",
            _stepped(lambda i, t: UPTIME + i * MS + (10 * MINUTE if i >= 300 else 0)),
        )
    )
    collect(reader.chunks("header"))
    assert reader.info.clock_steps == {}


@pytest.mark.parametrize("off", [-20 * 365 * DAY, 10 * 365 * DAY])
def test_a_few_stamps_years_off_are_glitches_not_steps(tmp_path: Path, off: int) -> None:
    """Two messages stamped years off (a flipped bit) in the middle, and three at the
    start: dropped by the rules for glitches, no step."""
    bad = {0, 1, 2, 400, 401}
    assert _said(tmp_path, _stepped(lambda i, t: t + off if i in bad else t))


def test_two_publishers_on_two_clocks_take_turns_without_a_step(tmp_path: Path) -> None:
    """Messages of one topic alternately stamped on two clocks a day apart (two
    publishers): every stretch is one message, none a clock of its own."""
    errors = _said(tmp_path, _stepped(lambda i, t: t - DAY * (i % 2)))
    assert any(e.startswith("/imu: header.stamp goes back by 86400.0 s") for e in errors)


# ------------------------------------------------------------------ a CSV's clock set back


def _csv(path: Path, cells: list[str], header: str = "time") -> Path:
    rng = np.random.default_rng(3)
    values = np.cumsum(rng.normal(size=(len(cells), 2)), axis=0)
    rows = [f"{c},{a:.4f},{b:.4f}" for c, (a, b) in zip(cells, values, strict=True)]
    path.write_text("\n".join([f"{header},a,b", *rows]) + "\n")
    return path


def _set_back(path: Path) -> Any:
    """The reader of ``path`` read through (no error raised: ``inspect`` lists it)."""
    reader = open_input(path)
    collect(reader.chunks())
    return reader


def test_a_csv_time_column_set_back_by_hours_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Seconds that step back by two hours at row 4001: before, the rows after it were
    sorted in among those before (interleaved), said in a line, and analyzed. ``run``
    and ``export`` refuse it in one line; ``inspect`` lists the file and says it, as it
    says a bag's header clock set during the recording (exit 0: at 580dd8d it stopped
    on it with exit 2)."""
    seconds = np.arange(6000) * 0.01 + 10_000.0
    seconds[4000:] -= 7200.0
    path = _csv(tmp_path / "back.csv", [f"{s:.2f}" for s in seconds])
    said = (
        "the time column 'time' steps back by 2.0 h at data row 4001 ('2840.00': "
        "from 10039.990 s to 2840.000 s): a clock set back during the recording? Its rows "
        "cannot be placed among those before it; correct the times, or split the file at "
        "that row"
    )
    reader = _set_back(path)
    assert reader.info.set_back == said
    assert reader.info.errors == [said]  # (the step's own note, of the same row, left out)
    assert main(["inspect", str(path)]) == 0
    out = capsys.readouterr().out
    assert f"  ! {said}\n" in out
    rows = [line.split()[:2] for line in out.splitlines() if line.split()[:1] in (["a"], ["b"])]
    assert rows == [["a", "6000"], ["b", "6000"]]  # (the table's rows, wherever its lines end)
    assert main(["inspect", str(path), "--json"]) == 0
    (listed,) = json.loads(capsys.readouterr().out)["inputs"]
    assert listed["errors"] == [said]
    for err in _refused(path, tmp_path, capsys):
        assert err == f"analyzer: error: {path}: {said}\n"


def test_a_csv_set_back_in_a_folder_of_files_stops_its_reading(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The middle one of three files set back: a damaged file of a multi-file archive
    (CONTRACT.md), not a refusal of the folder (the first version of the refusal: exit
    2). Its reading stops at the step, as at 580dd8d; ``run`` analyzes the others' rows
    (exit 0 or 1), its line under ``inputs[].errors`` and in the report; ``inspect``
    lists it, exit 0."""
    folder = tmp_path / "hours"
    folder.mkdir()
    first = np.arange(3000) * 0.01 + 10_000.0
    second = first + 30.0
    second[2000:] -= 7200.0
    _csv(folder / "a.csv", [f"{s:.2f}" for s in first])
    late = _csv(folder / "b.csv", [f"{s:.2f}" for s in second])
    _csv(folder / "c.csv", [f"{s:.2f}" for s in first + 60.0])
    said = (
        f"reading stopped: {late}: the time column 'time' steps back by 2.0 h at data row "
        "2001 ('2850.00': from 10049.990 s to 2850.000 s): a clock set back during the "
        "recording? Its rows cannot be placed among those before it; correct the times, "
        "or split the file at that row"
    )
    code = main(["run", str(folder), "--out", str(tmp_path / "o"), "--no-progress"])
    capsys.readouterr()
    assert code in (0, 1)
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    errors = {i["path"]: i["errors"] for i in doc["inputs"]}
    assert errors == {str(folder / "a.csv"): [], str(late): [said], str(folder / "c.csv"): []}
    assert {c["name"]: c["samples"] for c in doc["channels"]} == {"a": 6000, "b": 6000}
    assert said in html.unescape((tmp_path / "o" / "report.html").read_text())
    assert main(["inspect", str(folder)]) == 0
    assert f"  ! {said}\n" in capsys.readouterr().out


def test_a_csv_date_time_column_set_back_a_day_is_refused(tmp_path: Path) -> None:
    start = np.datetime64("2026-03-02T10:00:00.000")
    times = start + np.arange(3000) * np.timedelta64(10, "ms")
    times[2000:] -= np.timedelta64(1, "D")
    path = _csv(tmp_path / "iso.csv", [f"{t}Z" for t in times], header="timestamp")
    said = _set_back(path).info.set_back
    assert said.startswith("the time column 'timestamp' steps back by 24 h ")
    assert "at data row 2001 ('2026-03-01T10:00:20.000Z': " in said


def test_a_csv_step_back_under_the_hour_is_sorted_in_as_before(tmp_path: Path) -> None:
    seconds = np.arange(6000) * 0.01
    seconds[4000:] -= 3000.0  # 50 minutes back
    path = _csv(tmp_path / "back.csv", [f"{s:.2f}" for s in seconds])
    reader = open_input(path)
    assert collect(reader.chunks())["a"][0].size == 6000
    (note,) = reader.info.errors
    assert note.startswith("the time steps back by 50 min at data row 4001")


def test_a_csv_set_back_across_blocks_names_its_first_row(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Blocks of ~30 rows and the step moved over 40 rows: wherever a block ends (the
    run of rows set back starting in one block and reaching its fifth row in the next),
    the first row set back is named."""
    monkeypatch.setattr(csv_reader, "BLOCK_BYTES", 1 << 10)
    for step in range(500, 540):
        seconds = np.arange(1000) * 0.01 + 10_000.0
        seconds[step:] -= 7200.0
        path = _csv(tmp_path / f"back{step}.csv", [f"{s:.2f}" for s in seconds])
        cell = f"{seconds[step]:.2f}"
        assert f"2.0 h at data row {step + 1} ('{cell}': " in _set_back(path).info.set_back


@pytest.mark.parametrize("bad", [1, 4])
def test_a_few_csv_rows_far_back_are_outliers_as_before(tmp_path: Path, bad: int) -> None:
    """Up to 4 rows in a row stamped far back (a row stamped 0): no clock set back, the
    rows are sorted in and said, as before."""
    seconds = np.arange(3000) * 0.01 + 10_000.0
    seconds[2000 : 2000 + bad] = np.arange(bad) * 0.01
    path = _csv(tmp_path / "zero.csv", [f"{s:.2f}" for s in seconds])
    reader = open_input(path)
    assert collect(reader.chunks())["a"][0].size == 3000
    (note,) = reader.info.errors
    assert note.startswith("the time steps back by 2.8 h at data row 2001 ('0.00': ")

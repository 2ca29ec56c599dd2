"""``--time header`` on clocks the reorder rules of ``TopicTracker`` must not misread: a
simulation clock that starts at 0 (0 is a real time there, not "unset") and stamps
glitched far ahead of the messages around them (the glitch is dropped, not what follows
it). Logs are built with the real writers; the batch boundary is driven in code."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.writer import Writer as McapWriter
from readers_helpers import T0, collect
from test_readers_probe30 import MS, NAMES, ROS2, V3S, Message, v3s, write

from analyzer.readers import open_input
from analyzer.readers._common import Decoded, Reorderer, TopicTracker, forward_outliers

S = 10**9


def _read(path: Path, topic: str) -> tuple[np.ndarray, np.ndarray, list[str], Any]:
    reader = open_input(path)
    t, v = collect(reader.chunks("header"))[f"{topic}.vector.x"]
    return t, v, reader.info.errors, reader


def _small_chunks(path: Path, messages: list[Message]) -> Path:
    """``messages`` (one topic) in an MCAP of ~2 kB chunks: a batch every ~20 messages."""
    with path.open("wb") as handle:
        writer = McapWriter(handle, chunk_size=2000)
        writer.start(profile="ros2", library="test")
        text = ROS2.generate_msgdef(V3S, ros_version=2)[0]
        schema = writer.register_schema(V3S, "ros2msg", text.encode())
        channel = writer.register_channel(messages[0][0], "cdr", schema)
        for _, msgtype, t, make in messages:
            data = bytes(ROS2.serialize_cdr(make(ROS2), msgtype))
            writer.add_message(channel, log_time=t, data=data, publish_time=t)
        writer.finish()
    return path


# --------------------------------------------------------------------------- sim time


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_sim_time_from_zero_keeps_every_message(tmp_path: Path, fmt: str) -> None:
    """Gazebo's clock starts at 0: the first stamp is 0.00 s, then 0.01, 0.02 ... s,
    logged at wall-clock times. 0 is a real time on that clock: every message is kept at
    its stamp, nothing to say (it was given its log time, ~1.7e9 s, and the 999 messages
    after it were dropped as behind it)."""
    messages = [("/sim", V3S, T0 + i * MS, v3s(i * MS, i)) for i in range(1000)]
    t, v, errors, _ = _read(write(tmp_path / NAMES[fmt], fmt, messages), "/sim")
    assert t.tolist() == [i * MS for i in range(1000)]
    assert v.tolist() == list(range(1000))
    assert errors == []


def test_sim_time_decision_is_kept_across_batches(tmp_path: Path) -> None:
    """The topic is found to run on sim time in its first batch (0.00 s, 0.01 s ...); the
    simulator is then reset and paused at 0 for 60 messages (whole batches of stamps 0),
    and runs again from 0.01 s. The zeros stay real times: the reset is a clock that goes
    back by 3 s (dropped until the stamps pass 2.99 s again), not 60 messages at their
    wall-clock log times."""
    stamps = [i * MS for i in range(300)] + [0] * 60 + [(i - 359) * MS for i in range(360, 900)]
    messages = [("/sim", V3S, T0 + i * MS, v3s(stamps[i], i)) for i in range(900)]
    t, v, errors, _ = _read(_small_chunks(tmp_path / "reset.mcap", messages), "/sim")
    assert v.tolist() == list(range(300)) + list(range(659, 900))
    assert int(t.max()) < 10 * S
    assert errors == [
        "/sim: header.stamp goes back by 3.0 s at message 300 (t=3.00 s); 359 messages "
        "stamped before the newest stamp so far dropped (--time log keeps them)"
    ]


def test_wall_clock_topic_starting_with_zero_stamps_uses_log_time(tmp_path: Path) -> None:
    """A driver not yet synced at start: the first 5 stamps are 0, the rest wall-clock
    times (in the same batch). Those zeros are "unset": the log time is used, and said."""
    messages = [
        ("/z", V3S, T0 + i * MS, v3s(0 if i < 5 else T0 + i * MS - MS // 2, i)) for i in range(200)
    ]
    t, _, errors, _ = _read(write(tmp_path / "z.mcap", "mcap", messages), "/z")
    assert t.tolist() == sorted(T0 + i * MS - (0 if i < 5 else MS // 2) for i in range(200))
    assert errors == ["/z: 5 messages have header.stamp 0 (not set); their log time is used"]


# --------------------------------------------------------------------------- glitches


def _glitched(ahead: dict[int, int], n: int = 1000) -> list[Message]:
    return [("/imu", V3S, T0 + i * MS, v3s(T0 + i * MS + ahead.get(i, 0), i)) for i in range(n)]


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_forward_glitch_drops_the_glitch_not_what_follows(tmp_path: Path, fmt: str) -> None:
    """One stamp of 1000 is 100 s in the future (a GPS/PTP glitch): that message is
    dropped and named; the 899 messages after it were dropped as "behind" it before."""
    messages = _glitched({100: 100 * S})
    t, v, errors, reader = _read(write(tmp_path / NAMES[fmt], fmt, messages), "/imu")
    assert v.tolist() == [i for i in range(1000) if i != 100]
    assert t.tolist() == [T0 + i * MS for i in range(1000) if i != 100]
    assert errors == [
        "/imu: 1 message stamped more than 2 s ahead of the messages around them (the "
        "first: message 100, t=1.00 s, 100.0 s ahead): 1 dropped (--time log keeps them)"
    ]
    # the log clock keeps it, nothing to say
    reader = open_input(reader.info.path)
    assert collect(reader.chunks("log"))["/imu.vector.x"][1].size == 1000
    assert reader.info.errors == []


@pytest.mark.parametrize("fmt", ["mcap", "ros2"])
def test_forward_glitch_at_the_first_message(tmp_path: Path, fmt: str) -> None:
    """The topic's very first stamp is 100 s ahead: with nothing before it, the two
    messages after it agree with each other and not with it: it is the glitch."""
    t, v, errors, _ = _read(write(tmp_path / NAMES[fmt], fmt, _glitched({0: 100 * S})), "/imu")
    assert v.tolist() == list(range(1, 1000))
    assert errors == [
        "/imu: 1 message stamped more than 2 s ahead of the messages around them (the "
        "first: message 0, t=0.00 s, 100.0 s ahead): 1 dropped (--time log keeps them)"
    ]


def test_short_run_of_glitched_stamps(tmp_path: Path) -> None:
    """Five messages in a row 100 s ahead (and a second such run later): both runs are
    dropped, nothing else."""
    ahead = {i: 100 * S for i in (*range(100, 105), *range(600, 603))}
    _, v, errors, _ = _read(write(tmp_path / "run.bag", "ros1", _glitched(ahead)), "/imu")
    assert v.tolist() == [i for i in range(1000) if i not in ahead]
    assert errors == [
        "/imu: 8 messages stamped more than 2 s ahead of the messages around them (the "
        "first: message 100, t=1.00 s, 100.0 s ahead): 8 dropped (--time log keeps them)"
    ]


def test_glitch_in_small_batches(tmp_path: Path) -> None:
    """Every 11th message 50 s ahead, in a file of ~20-message batches: some glitches are
    the last message of their batch. None drops the messages after it; those at a batch's
    end were passed on before the next batch showed them: kept, and counted apart."""
    ahead = {i: 50 * S for i in range(3, 1000, 11)}
    t, v, errors, _ = _read(_small_chunks(tmp_path / "small.mcap", _glitched(ahead)), "/imu")
    normal = [i for i in range(1000) if i not in ahead]
    kept = sorted(set(v.tolist()) - set(normal))
    assert v.tolist() == normal + kept and 0 < len(kept) < len(ahead)
    assert bool(np.all(t[len(normal) :] > T0 + 50 * S))
    assert errors == [
        f"/imu: {len(ahead)} messages stamped more than 2 s ahead of the messages around them "
        f"(the first: message 3, t=0.03 s, 50.0 s ahead): {len(ahead) - len(kept)} dropped, "
        f"{len(kept)} kept (passed on at the end of a batch, before the next message showed "
        "them; they no longer count as the newest stamp) (--time log keeps them)"
    ]


STEPPED = (
    "/imu: header.stamp jumps 100 s forward at message 100 (t=1.00 s), from "
    "2026-01-01T00:00:00.990Z to 2026-01-01T00:01:41.000Z, while its log times go on (a "
    "clock set during the recording?)"
)


def test_clock_that_steps_forward_and_stays_is_kept(tmp_path: Path) -> None:
    """A clock corrected forward by 100 s (and staying there) is no glitch: all kept, and
    the step named (a wall clock's step is 10 s: ``run`` and ``export`` of the topic
    refuse it, see ``test_clock_steps.py``)."""
    ahead = {i: 100 * S for i in range(100, 1000)}
    _, v, errors, _ = _read(write(tmp_path / "fwd.mcap", "mcap", _glitched(ahead)), "/imu")
    assert v.size == 1000
    assert errors == [f"{STEPPED}; use --time log, or leave it out with --channels '!/imu.*'"]


def test_long_forward_excursion_is_a_clock_step(tmp_path: Path) -> None:
    """100 s ahead for 3 s of messages (longer than the window), then back: not a glitch
    but two clock steps; the stretch after the step back is behind the newest stamp and
    dropped by the running-maximum rule, as for any clock that goes back."""
    ahead = {i: 100 * S for i in range(100, 400)}
    _, v, errors, _ = _read(write(tmp_path / "long.mcap", "mcap", _glitched(ahead)), "/imu")
    assert v.tolist() == list(range(400))
    assert len(errors) == 2 and errors[0].startswith(f"{STEPPED}; 2 such jumps; use --time log")
    assert "goes back by 100.0 s at message 400" in errors[1]


def _decoded(x: np.ndarray, stamps: np.ndarray) -> Decoded:
    return Decoded(int(x.size), {"x": (None, x.astype(np.float64))}, stamps.astype(np.int64))


def test_glitch_at_a_batch_boundary_does_not_drop_what_follows() -> None:
    """The glitch is the last message of its batch: it has been passed on when the next
    batch shows it was one. It is kept (and said), but it no longer counts as the newest
    stamp: the next batch is kept whole."""
    n = 400
    i = np.arange(n)
    log = T0 + i * MS
    stamps = log.copy()
    stamps[199] += 100 * S
    tracker = TopicTracker("header")
    reorder = Reorderer(repeats=True)
    tracker.push(reorder, "/b", _decoded(i[:200], stamps[:200]), log[:200])
    tracker.push(reorder, "/b", _decoded(i[200:], stamps[200:]), log[200:])
    t, v = collect(reorder.flush())["/b.x"]
    assert v.tolist() == [k for k in range(n) if k != 199] + [199]  # in time order
    assert int(t[-1]) == int(stamps[199])
    assert tracker.lines() == [
        "/b: 1 message stamped more than 2 s ahead of the messages around them (the first: "
        "message 199, t=1.99 s, 100.0 s ahead): 0 dropped, 1 kept (passed on at the end of "
        "a batch, before the next message showed them; they no longer count as the newest "
        "stamp) (--time log keeps them)"
    ]


@pytest.mark.parametrize("batch", [1, 2, 3])
def test_glitch_at_the_first_message_in_tiny_batches(batch: int) -> None:
    """The topic's first stamp is 100 s ahead and its batches hold 1 to 3 messages: the
    first message waits (out of the running maximum) until two messages after it show
    which clock is right. In batches of 1 or 2 it was passed on by then (kept, said);
    in a batch of 3 it is dropped."""
    n = 300
    i = np.arange(n)
    log = T0 + i * MS
    stamps = log.copy()
    stamps[0] += 100 * S
    tracker = TopicTracker("header")
    reorder = Reorderer(repeats=True)
    for a in range(0, n, batch):
        part = slice(a, a + batch)
        tracker.push(reorder, "/b", _decoded(i[part], stamps[part]), log[part])
    v = collect(reorder.flush())["/b.x"][1]
    kept = batch < 3
    assert v.tolist() == list(range(1, n)) + [0] * kept
    head = (
        "/b: 1 message stamped more than 2 s ahead of the messages around them (the "
        "first: message 0, t=0.00 s, 100.0 s ahead): "
    )
    tail = (
        "0 dropped, 1 kept (passed on at the end of a batch, before the next message "
        "showed them; they no longer count as the newest stamp)"
        if kept
        else "1 dropped"
    )
    assert tracker.lines() == [head + tail + " (--time log keeps them)"]


def test_glitch_run_across_a_batch_boundary() -> None:
    """A run of 4 glitched stamps, 2 at the end of a batch and 2 at the start of the
    next: the 2 not yet passed on are dropped, the rest of the topic is kept."""
    n = 400
    i = np.arange(n)
    log = T0 + i * MS
    stamps = log.copy()
    stamps[198:202] += 100 * S
    tracker = TopicTracker("header")
    reorder = Reorderer(repeats=True)
    tracker.push(reorder, "/b", _decoded(i[:200], stamps[:200]), log[:200])
    tracker.push(reorder, "/b", _decoded(i[200:], stamps[200:]), log[200:])
    v = collect(reorder.flush())["/b.x"][1]
    assert v.tolist() == [k for k in range(n) if k not in range(198, 202)] + [198, 199]
    assert ": 2 dropped, 2 kept" in tracker.lines()[0]


def test_forward_outliers_rules() -> None:
    """The rule on offsets alone: a lone forward outlier and a short run are glitches;
    a backward outlier, a step that stays and a monotonic clock with uneven log times
    are not; the stretch at the end is open only when it is ahead of what came before."""
    w = 2 * S
    log = np.arange(10, dtype=np.int64) * S
    flat = log.copy()
    one = flat.copy()
    one[4] += 100 * S
    glitch, pending, ahead, _ = forward_outliers(one, log, 0, w)
    assert np.flatnonzero(glitch).tolist() == [4] and not pending.any()
    assert int(ahead[4]) == 100 * S
    back = flat.copy()
    back[4] -= 100 * S
    assert not forward_outliers(back, log, 0, w)[0].any()
    step = flat + np.where(np.arange(10) >= 4, 100 * S, 0)
    assert not forward_outliers(step, log, 0, w)[0].any()
    # a slow topic on a clock that runs 4x faster than the log clock: offsets grow by 3 s
    # and more per message, but the stamps never go back. The last 2 s (messages 7-9, all
    # more than 2 s above message 6) stay open: a run's offsets need not agree, so the
    # three could still be one glitch if the next message went back to message 6's
    fast = log * 4
    glitch, pending, _, _ = forward_outliers(fast, log, 0, w)
    assert not glitch.any() and np.flatnonzero(pending).tolist() == [7, 8, 9]
    tail = flat.copy()
    tail[9] += 100 * S
    glitch, pending, _, _ = forward_outliers(tail, log, 0, w)
    assert not glitch.any() and np.flatnonzero(pending).tolist() == [9]
    assert not forward_outliers(flat, log, 0, w)[1].any()


# --------------------------------------------------------------------------- runs of glitches
# bad stamps in a row seldom agree with each other: the run is tested as a whole against
# the messages around it


@pytest.mark.parametrize("fmt", ["mcap", "ros1", "ros2"])
def test_adjacent_glitches_that_disagree_are_one_run(tmp_path: Path, fmt: str) -> None:
    """Messages 100 and 101 are stamped 100 s and 37 s ahead: one run of two, both above
    the messages around it, dropped. Before, each was a stretch of its own and neither
    had agreeing neighbours: message 100 became the newest stamp and the 899 messages
    from 101 on were dropped as behind it (101 of 1000 kept)."""
    ahead = {100: 100 * S, 101: 37 * S}
    t, v, errors, _ = _read(write(tmp_path / NAMES[fmt], fmt, _glitched(ahead)), "/imu")
    assert v.tolist() == [i for i in range(1000) if i not in ahead]
    assert t.tolist() == [T0 + i * MS for i in range(1000) if i not in ahead]
    assert errors == [
        "/imu: 2 messages stamped more than 2 s ahead of the messages around them (the "
        "first: message 100, t=1.00 s, 100.0 s ahead): 2 dropped (--time log keeps them)"
    ]


def test_disagreeing_glitches_at_the_first_messages(tmp_path: Path) -> None:
    """The topic's first two stamps are 100 s and 50 s ahead: the first run is both (at
    most 4 messages, the two after it agree). Before, the 999 messages after the first
    were dropped as behind it (1 of 1000 kept)."""
    path = write(tmp_path / "lead.mcap", "mcap", _glitched({0: 100 * S, 1: 50 * S}))
    _, v, errors, _ = _read(path, "/imu")
    assert v.tolist() == list(range(2, 1000))
    assert errors == [
        "/imu: 2 messages stamped more than 2 s ahead of the messages around them (the "
        "first: message 0, t=0.00 s, 100.0 s ahead): 2 dropped (--time log keeps them)"
    ]


def test_a_lone_glitch_then_a_disagreeing_pair(tmp_path: Path) -> None:
    """One glitch (+100 s at message 100), then a pair (+50 s, +20 s at 300 and 301):
    three dropped, the rest kept (300 of 1000 before)."""
    ahead = {100: 100 * S, 300: 50 * S, 301: 20 * S}
    _, v, errors, _ = _read(write(tmp_path / "three.mcap", "mcap", _glitched(ahead)), "/imu")
    assert v.tolist() == [i for i in range(1000) if i not in ahead]
    assert errors == [
        "/imu: 3 messages stamped more than 2 s ahead of the messages around them (the "
        "first: message 100, t=1.00 s, 100.0 s ahead): 3 dropped (--time log keeps them)"
    ]


def test_disagreeing_run_across_a_batch_boundary() -> None:
    """A batch ends with stamps 50 s and 100 s ahead, the next starts back on time: the
    two stay open together (the earliest start that is still ahead), so the next batch
    shows them as one run; they were passed on (kept, said) and set no newest stamp.
    Before, only the last was held open: the first set the newest stamp and the 200
    messages of the next batch were dropped as behind it."""
    n = 400
    i = np.arange(n)
    log = T0 + i * MS
    stamps = log.copy()
    stamps[198] += 50 * S
    stamps[199] += 100 * S
    tracker = TopicTracker("header")
    reorder = Reorderer(repeats=True)
    tracker.push(reorder, "/b", _decoded(i[:200], stamps[:200]), log[:200])
    tracker.push(reorder, "/b", _decoded(i[200:], stamps[200:]), log[200:])
    v = collect(reorder.flush())["/b.x"][1]
    assert v.tolist() == [k for k in range(n) if k not in (198, 199)] + [198, 199]
    assert tracker.lines() == [
        "/b: 2 messages stamped more than 2 s ahead of the messages around them (the first: "
        "message 198, t=1.98 s, 50.0 s ahead): 0 dropped, 2 kept (passed on at the end of "
        "a batch, before the next message showed them; they no longer count as the newest "
        "stamp) (--time log keeps them)"
    ]


def test_glitch_on_the_last_message_is_said(tmp_path: Path) -> None:
    """The topic's last stamp is 100 s ahead: nothing after it tells a glitch from a
    clock that stepped forward, and it was passed on before the end was known. It is
    kept, as before, but said (nothing was said before); a clock that steps forward and
    stays, earlier in the file, is still not said
    (:func:`test_clock_that_steps_forward_and_stays_is_kept`)."""
    t, v, errors, _ = _read(
        write(tmp_path / "last.mcap", "mcap", _glitched({999: 100 * S})), "/imu"
    )
    assert v.size == 1000 and int(t[-1]) == T0 + 999 * MS + 100 * S
    assert errors == [
        "/imu: the last message read is stamped more than 2 s ahead of the message "
        "before it (message 999, t=9.99 s, 100.0 s ahead): kept (with no "
        "message after it, a glitch cannot be told from a clock that stepped forward) "
        "(--time log keeps it)"
    ]


def test_forward_outliers_runs() -> None:
    """The run rule on offsets alone: a run whose offsets disagree (+100, +37) is one
    glitch; runs nest (0, +50, +100, +50, 0: the outer run is the three, each measured
    against the messages around it); a step back of 3 or 5 s that stays, or that comes
    back up after a while, has no run above its neighbours; a run longer than the window
    is a step."""
    w = 2 * S
    log = np.arange(12, dtype=np.int64) * S // 10  # 10 Hz
    pair = log.copy()
    pair[4] += 100 * S
    pair[5] += 37 * S
    glitch, pending, ahead, aside = forward_outliers(pair, log, 0, w)
    assert np.flatnonzero(glitch).tolist() == [4, 5] and not pending.any()
    assert (aside == glitch).all() and ahead[[4, 5]].tolist() == [100 * S, 37 * S]
    nest = log.copy()
    nest[4:7] += np.array([50, 100, 50]) * S
    glitch, _, ahead, _ = forward_outliers(nest, log, 0, w)
    assert np.flatnonzero(glitch).tolist() == [4, 5, 6]
    assert ahead[[4, 5, 6]].tolist() == [50 * S, 100 * S, 50 * S]
    for back in (3 * S, 5 * S):
        step = log - np.where(np.arange(12) >= 4, back, 0)
        assert not forward_outliers(step, log, 0, w)[0].any()
        dip = log - np.where((np.arange(12) >= 4) & (np.arange(12) < 8), back, 0)
        glitch, pending, _, _ = forward_outliers(dip, log, 0, w)
        assert not glitch.any() and np.flatnonzero(pending).tolist() == [8, 9, 10, 11]
    slow = np.arange(12, dtype=np.int64) * S  # 1 Hz: a 3 s run is a step, not a glitch
    long = slow.copy()
    long[4:8] += np.array([100, 37, 60, 80]) * S
    assert not forward_outliers(long, slow, 0, w)[0].any()

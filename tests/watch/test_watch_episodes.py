"""The watcher's fault episodes (``index.json``'s ``episodes``, ``index.html``): a fault
that goes on from one archive into the next is one line, from its first onset to its last
end; anything in between that breaks the chain (a healthy archive, a gap, a fault that is
not there from the next archive's start) ends it."""

from __future__ import annotations

import contextlib
import json
from pathlib import Path
from typing import Any

import numpy as np
from test_watch_run import (
    _stop_fork_server,  # noqa: F401 - stops the local watcher's server
)

from analyzer.cli import main
from analyzer.pipeline import load_options
from analyzer.simulate import inject_fault, simulate_building
from analyzer.watch import WatchSettings, watch
from analyzer.watch_index import JOIN_GAP_S, Record, Verdict, episodes, index_view
from analyzer.writers import write_archive


def _rec(
    name: str, start: str | None, faults: list[dict[str, Any]], duration: float = 3600.0
) -> Record:
    return Record(
        name=name,
        sha256="0",
        verdict=Verdict.FAULT if faults else Verdict.NO_FAULT,
        report=f"{name}/report.html",
        inputs=[name],
        processed="2026-01-02T00:00:00.000Z",
        analysis_s=1.0,
        start=start,
        duration_s=duration,
        fault_list=faults,
    )


def _f(channel: str, onset: str, end: str | None, from_start: Any, kind: str = "additive"):
    return {"channel": channel, "type": kind, "onset": onset, "end": end, "from_start": from_start}


H0, H1, H2, H3 = (f"2026-03-02T{h:02d}:00:00.000Z" for h in (0, 1, 2, 3))


def test_a_fault_going_on_across_hourly_archives_is_one_episode():
    recs = [
        _rec("h0", H0, [_f("s5", "2026-03-02T00:30:00.000Z", None, False)]),
        _rec(
            "h1", H1, [_f("s5", H1, None, True), _f("s2", "2026-03-02T01:10:00.000Z", None, False)]
        ),
        _rec("h2", H2, [_f("s5", H2, "2026-03-02T02:20:00.000Z", True, kind="drift")]),
    ]
    eps = episodes(reversed(recs))  # whatever the order they come in
    assert eps == [
        {
            "channel": "s5",
            "types": ["additive", "drift"],
            "size": None,  # (records of older watchers: no size)
            "onset": "2026-03-02T00:30:00.000Z",
            "from_start": False,
            "end": "2026-03-02T02:20:00.000Z",
            "archives": ["h0", "h1", "h2"],
        },
        {  # lasted to the end of h1, but h2 does not have it from its start
            "channel": "s2",
            "types": ["additive"],
            "size": None,
            "onset": "2026-03-02T01:10:00.000Z",
            "from_start": False,
            "end": None,
            "archives": ["h1"],
        },
    ]


def test_what_breaks_an_episode():
    open_s5 = _f("s5", "2026-03-02T00:30:00.000Z", None, False)
    # a healthy archive in between
    eps = episodes(
        [_rec("h0", H0, [open_s5]), _rec("h1", H1, []), _rec("h2", H2, [_f("s5", H2, None, True)])]
    )
    assert [e["archives"] for e in eps] == [["h0"], ["h2"]]
    # the next archive starts later than the gap allows
    late = f"2026-03-02T01:00:{JOIN_GAP_S + 1:06.3f}Z"
    eps = episodes([_rec("h0", H0, [open_s5]), _rec("h1", late, [_f("s5", late, None, True)])])
    assert [e["archives"] for e in eps] == [["h0"], ["h1"]]
    # within the gap: joined
    near = f"2026-03-02T01:00:{JOIN_GAP_S - 1:06.3f}Z"
    eps = episodes([_rec("h0", H0, [open_s5]), _rec("h1", near, [_f("s5", near, None, True)])])
    assert [e["archives"] for e in eps] == [["h0", "h1"]]
    # not there from the next archive's start (a new onset), or ended before its archive did
    later_onset = _f("s5", "2026-03-02T01:05:00.000Z", None, False)
    ended = _f("s5", "2026-03-02T00:30:00.000Z", "2026-03-02T00:40:00.000Z", False)
    for first, second in ((open_s5, later_onset), (ended, _f("s5", H1, None, True))):
        eps = episodes([_rec("h0", H0, [first]), _rec("h1", H1, [second])])
        assert [e["archives"] for e in eps] == [["h0"], ["h1"]]
    # archives without absolute times: each fault on its own
    eps = episodes([_rec("a", None, [open_s5]), _rec("b", None, [_f("s5", H1, None, True)])])
    assert [e["archives"] for e in eps] == [["a"], ["b"]]


def test_an_episode_there_from_its_first_archives_start_says_from_the_start():
    """A fault there from the first sample searched of its first archive may have begun
    before it: the episode carries ``from_start`` and the index says "from the start",
    and the time before which nothing was judged, as ``analyzer run``'s report does
    (before, a plain onset: the end of the filters' warm-up, a made-up time)."""
    recs = [
        _rec("h0", H0, [_f("s5", "2026-03-02T00:00:03.600Z", None, True)]),
        _rec(
            "h1", H1, [_f("s5", H1, None, True), _f("s2", "2026-03-02T01:10:00.000Z", None, False)]
        ),
    ]
    eps = episodes(recs)
    assert [(e["channel"], e["from_start"], e["archives"]) for e in eps] == [
        ("s5", True, ["h0", "h1"]),
        ("s2", False, ["h1"]),
    ]
    index = {
        "archives": [],
        "episodes": eps,
        "counts": {"fault": 2, "no fault": 0, "error": 0},
        "analyzer_version": "0",
        "updated": "",
    }
    onsets = [row.onset for row in index_view(index).episodes]
    # (said as analyzer run's line says it since ux53 item 8; it read "at or before")
    assert onsets == [
        "from the start (not judged before 2026-03-02T00:00:03.600Z)",
        "2026-03-02T01:10:00.000Z",
    ]


T0, T1, T2 = (f"2026-03-02T14:0{m}:00.000Z" for m in (2, 3, 4))


def _at(second: float) -> str:
    """14:02:00 plus ``second`` seconds, as an ISO time."""
    minutes, rest = divmod(second, 60.0)
    return f"2026-03-02T14:{2 + int(minutes):02d}:{rest:06.3f}Z"


def _rated(rec: Record, rate: float) -> None:
    """``rec`` with its sample rate (none in the records of older watchers: so that the
    assertions below, not this, fail on a watcher without it)."""
    with contextlib.suppress(AttributeError):
        rec.rate_hz = rate


def _s2(*extra: Record) -> list[list[str]]:
    """The s2 episodes' archives of the audit's INBOX: h14 and h15 (consecutive minutes,
    an offset on s2 through both, 10 samples a second) with ``extra``, in any order."""
    recs = [
        _rec("h14.csv", T0, [_f("s2", _at(3.6), None, True)], 60.0),
        _rec("h15.csv", T1, [_f("s2", T1, None, True)], 60.0),
        *extra,
    ]
    for rec in recs:
        _rated(rec, 10.0)
    out = [e["archives"] for e in episodes(recs) if e["channel"] == "s2"]
    assert out == [e["archives"] for e in episodes(reversed(recs)) if e["channel"] == "s2"]
    return out


def test_an_archive_overlapping_rather_than_between_does_not_split_an_episode():
    """The audit's INBOX with transient (the same minute as h14, other data, no s2
    fault): one episode (before: two, split by transient). An archive with no s2 fault
    never splits it, wherever it lies: inside h14's last seconds, over the join, or
    following h14 beside h15 (before: a file inside h14's last 5 s split it, and which
    of two followers decided went by their names)."""
    assert _s2() == [["h14.csv", "h15.csv"]]
    s0_gain = _f("s0", _at(20.0), None, False, kind="gain")
    assert _s2(_rec("transient.csv", T0, [s0_gain], 60.0)) == [["h14.csv", "h15.csv"]]
    for name in ("a_other.csv", "z_other.csv"):
        for start, seconds in ((_at(56.0), 2.0), (_at(54.0), 26.0), (T1, 60.0)):
            assert _s2(_rec(name, start, [], seconds)) == [["h14.csv", "h15.csv"]], (name, start)
    # (a healthy archive that takes the time between them ends it: h15 no longer follows)
    assert _s2(
        _rec("between.csv", T1, [], 60.0), _rec("h16.csv", T2, [_f("s2", T2, None, True)], 60.0)
    ) == [["h14.csv", "h15.csv", "h16.csv"]]


def test_an_overlapping_archive_with_the_same_fault_joins_its_episode():
    """A file over h14's and h15's join with the s2 fault from its start (a second
    recorder's, a duplicate) is part of the one episode (before: three, ``[h14] [x]
    [h15]``); a duplicate of h14 does not take h14's place (before: ``[a_dup, h15]`` and
    ``[h14]`` alone, by the names)."""
    x = _rec("x.csv", _at(30.0), [_f("s2", _at(30.0), None, True)], 60.0)
    assert _s2(x) == [["h14.csv", "x.csv", "h15.csv"]]
    dup = _rec("a_dup.csv", T0, [_f("s2", _at(3.6), None, True)], 60.0)
    assert _s2(dup) == [["a_dup.csv", "h14.csv", "h15.csv"]]
    # (a fault of the same sensor that ended before the overlapping file's began: its own)
    h14 = _rec("h14.csv", T0, [_f("s2", _at(3.6), _at(10.0), False)], 60.0)
    y = _rec("y.csv", _at(30.0), [_f("s2", _at(40.0), _at(45.0), False)], 20.0)
    assert [e["archives"] for e in episodes([h14, y])] == [["h14.csv"], ["y.csv"]]


def test_the_join_gap_and_tolerance_follow_the_sample_period():
    """A following archive may start up to one sample period before the earlier one's
    end (at least 1 ms) and up to the longer of 5 s and 2.5 sample periods after it: a
    minute-rate logger that lost one sample at a rotation is not split (before: a fixed
    5 s, so one lost sample of a slow logger always split; and 5 s before the end)."""

    def joined(rate: float, first_s: float, second_start_s: float) -> bool:
        a = _rec("a", T0, [_f("s2", T0, None, True)], first_s)
        b = _rec("b", _at(second_start_s), [_f("s2", _at(second_start_s), None, True)], 600.0)
        _rated(a, rate)
        _rated(b, rate)
        return len(episodes([a, b])) == 1

    minute = 1.0 / 60.0
    assert joined(minute, 600.0, 600.0 + 120.0)  # (one sample lost: two periods)
    assert not joined(minute, 600.0, 600.0 + 151.0)  # (more than 2.5 periods)
    assert joined(10.0, 60.0, 60.0 + JOIN_GAP_S - 0.1)
    assert not joined(10.0, 60.0, 60.0 + JOIN_GAP_S + 0.1)
    assert joined(10.0, 60.0, 59.95)  # (within one period before the end)


def test_watcher_joins_a_fault_across_two_consecutive_files(tmp_path: Path):
    """One continuous record cut into a healthy file (the model's) and two files audited
    with ``--model``: an offset from the middle of the first goes on through the second."""
    rate = 100.0
    t, y, names = simulate_building(3, 100.0, rate, seed=11)
    y[:, 1] = inject_fault(y[:, 1], rate, "additive", 50.0, 8.0 * y[:3000, 1].std())
    t_ns = np.round(t * 1e9).astype(np.int64)

    def cut(path: Path, a_s: float, b_s: float) -> Path:
        rows = slice(int(a_s * rate), int(b_s * rate))
        data = {n: y[rows, i] for i, n in enumerate(names)}
        # (write_archive puts the first sample at start_iso: each file's own start)
        begin = f"2026-01-01T00:{int(a_s) // 60:02d}:{a_s % 60:06.3f}Z"
        write_archive(path, "mcap", t_ns[rows], data, start_iso=begin)
        return path

    cut(tmp_path / "healthy.mcap", 0.0, 30.0)
    inbox = tmp_path / "inbox"
    inbox.mkdir()
    cut(inbox / "part1.mcap", 30.0, 65.0)
    cut(inbox / "part2.mcap", 65.0, 100.0)
    model = tmp_path / "m.model"
    fit = ["run", str(tmp_path / "healthy.mcap"), "--out", str(tmp_path / "fit")]
    assert main([*fit, "--train", "0:30", "--save-model", str(model), "--no-progress"]) == 0
    reports = tmp_path / "reports"
    options = load_options(None, model=str(model))
    assert watch(WatchSettings(inbox, reports, settle=0.2, once=True, jobs=2), options) == 1

    index = json.loads((reports / "index.json").read_text())
    faulty = [e for e in index["episodes"] if e["channel"] == "/s1.data"]
    assert len(faulty) == 1, index["episodes"]
    (ep,) = faulty
    assert ep["archives"] == ["part1.mcap", "part2.mcap"] and ep["types"] == ["additive"]
    assert abs(
        np.datetime64(ep["onset"].rstrip("Z")) - np.datetime64("2026-01-01T00:00:50")
    ) < np.timedelta64(1, "s")
    assert ep["end"] is None  # it lasts to the end of the latest file
    page = (reports / "index.html").read_text()
    assert "2 archives: part1.mcap to part2.mcap" in page

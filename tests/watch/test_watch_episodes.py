"""The watcher's fault episodes (``index.json``'s ``episodes``, ``index.html``): a fault
that goes on from one archive into the next is one line, from its first onset to its last
end; anything in between that breaks the chain (a healthy archive, a gap, a fault that is
not there from the next archive's start) ends it."""

from __future__ import annotations

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


def test_an_episode_there_from_its_first_archives_start_says_at_or_before():
    """A fault there from the first sample searched of its first archive may have begun
    before it: the episode carries ``from_start`` and the index says "at or before", as
    ``analyzer run``'s report does (before, a plain onset: the end of the filters'
    warm-up, a made-up time)."""
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
    assert onsets == ["at or before 2026-03-02T00:00:03.600Z", "2026-03-02T01:10:00.000Z"]


def _chan(rec: Record, channels: list[str] | None) -> Record:
    rec.channels = channels
    return rec


def test_an_archive_overlapping_rather_than_between_does_not_split_an_episode():
    """The audit's INBOX: h14 and h15 (consecutive minutes, an offset on s2 through both)
    and transient (the same minute as h14, other data, no s2 fault). transient lies over
    h14's span, not in the gap between h14 and h15: one episode (before: two, split by
    transient). Only an archive that follows h14 and analyzed s2 without the fault
    breaks it; one of another source (no s2) does not."""
    t0, t1 = "2026-03-02T14:02:00.000Z", "2026-03-02T14:03:00.000Z"
    s0_gain = _f("s0", "2026-03-02T14:02:20.000Z", None, False, kind="gain")

    def inbox(*extra: Record) -> list[list[str]]:
        recs = [
            _chan(
                _rec("h14.csv", t0, [_f("s2", "2026-03-02T14:02:03.600Z", None, True)], 60.0), None
            ),
            _chan(_rec("h15.csv", t1, [_f("s2", t1, None, True)], 60.0), ["s0", "s2"]),
            *extra,
        ]
        return [e["archives"] for e in episodes(recs) if e["channel"] == "s2"]

    assert inbox() == [["h14.csv", "h15.csv"]]
    transient = _chan(_rec("transient.csv", t0, [s0_gain], 60.0), ["s0", "s2"])
    assert inbox(transient) == [["h14.csv", "h15.csv"]]
    # (a healthy archive of s2 in the gap between them, as before, ends it)
    between = _chan(_rec("between.csv", t1, [], 60.0), ["s0", "s2"])
    assert inbox(between) == [["h14.csv"], ["h15.csv"]]
    # (one in the gap that did not analyze s2: another source's; it does not)
    other = _chan(_rec("between.csv", t1, [], 60.0), ["t0", "t1"])
    assert inbox(other) == [["h14.csv", "h15.csv"]]


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

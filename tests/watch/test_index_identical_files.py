"""Byte-identical archives under two names (one file copied in twice) are each analyzed
(the watcher's content check goes by name) and the index said their fault episode was
"2 archives: offset_copy.csv to offset_mid.csv", which read as a span of two files over
time (ux53 item 9). It says the copy as such, and a span of other archives still as one."""

from __future__ import annotations

from typing import Any

from analyzer.watch_index import index_view


def _row(name: str, sha: str, processed: str) -> dict[str, Any]:
    return {
        "name": name,
        "sha256": sha,
        "processed": processed,
        "verdict": "fault",
        "error": None,
        "report": f"{name}/report.html",
        "faulty_sensors": ["s2"],
        "start": "2026-03-07T14:00:00.000Z",
        "duration_s": 60.0,
        "moved_to": [],
    }


def _view(rows: list[dict[str, Any]], archives: list[str]) -> Any:
    (ep,) = index_view(
        {
            "analyzer_version": "test",
            "updated": "now",
            "archives": rows,
            "episodes": [
                {
                    "channel": "s2",
                    "types": ["additive"],
                    "size": "offset +1.914",
                    "onset": "2026-03-07T14:00:30.000Z",
                    "from_start": False,
                    "end": None,
                    "archives": archives,
                }
            ],
            "counts": {"fault": len(rows), "no fault": 0, "error": 0},
        }
    ).episodes
    return ep


def test_a_copy_under_another_name_is_said_as_identical_not_as_a_span():
    rows = [
        _row("offset_copy.csv", "same", "2026-12-07T10:00:05Z"),
        _row("offset_mid.csv", "same", "2026-12-07T10:00:01Z"),  # (analyzed first)
    ]
    ep = _view(rows, ["offset_copy.csv", "offset_mid.csv"])
    assert ep.archives == "offset_mid.csv (and 1 identical file: offset_copy.csv)"
    assert ep.end == "to the end of offset_mid.csv"
    assert ep.href == "offset_mid.csv/report.html"


def test_archives_of_other_contents_are_still_a_span():
    rows = [
        _row("h1.csv", "one", "2026-12-07T10:00:01Z"),
        _row("h1-copy.csv", "one", "2026-12-07T10:00:09Z"),
        _row("h1-again.csv", "one", "2026-12-07T10:00:08Z"),
        _row("h2.csv", "two", "2026-12-07T10:00:02Z"),
    ]
    ep = _view(rows, ["h1-copy.csv", "h1.csv", "h1-again.csv", "h2.csv"])
    # every archive counted, the identical ones too (it said "2 archives" of these 4,
    # the index's counts 4)
    assert ep.archives == (
        "4 archives: h1.csv (and 2 identical files: h1-again.csv, h1-copy.csv) to h2.csv"
    )
    assert _view(rows[3:], ["h2.csv"]).archives == "h2.csv"

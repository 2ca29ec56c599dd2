"""A topic that stops for good while the others go on (an IMU whose last message is at
40 % of the record), and one that starts late (rob56 #1). The stop was said in
findings.json's notes and among the report's "other notes" alone; stderr ended with
"no sensor fault found", which read as the whole record audited. A topic whose messages
stop is no fault finding (README): the run now says it once, in one note repeated on
stderr and beside the report's verdict, and its last line names it."""

from __future__ import annotations

import html
import re
from pathlib import Path

import numpy as np
from cli_helpers import run_to, said, schema_valid

from analyzer.simulate import simulate_building
from analyzer.writers import write_archive

T0 = 1_780_000_000_000_000_000


def _robot(tmp_path: Path, keep0: float, start1: float = 0.0) -> Path:
    """A folder of two MCAPs recorded together (a healthy 6-floor building at 200 Hz,
    120 s): ``/imu0`` (s0-s2) with messages before ``keep0`` seconds only, ``/s3``,
    ``/s4`` and ``/s5`` from ``start1`` seconds on."""
    t, y, names = simulate_building(n_floors=6, duration_s=120.0, seed=4)
    t_ns = T0 + np.round(t * 1e9).astype(np.int64)
    folder = tmp_path / "rec"
    folder.mkdir()
    for file, cols, keep, layout in (
        ("a.mcap", range(3), t < keep0, "imu"),
        ("b.mcap", range(3, 6), t >= start1, "float64"),
    ):
        data = {names[j]: y[keep, j] for j in cols}
        write_archive(folder / file, "mcap", t_ns[keep], data, layout=layout)
    return folder


def _report_text(out: Path) -> str:
    return re.sub(
        r"\s+", " ", html.unescape(re.sub(r"<[^>]+>", " ", (out / "report.html").read_text()))
    )


def test_a_topic_that_stops_for_good_is_said_once_on_stderr(tmp_path, capsys):
    code, err, doc, out = run_to(tmp_path, capsys, _robot(tmp_path, 48.0), "--jobs", "1")
    assert code == 0, err
    schema_valid(doc)
    stop = "have no reading in their last 72 s (after 48 s) of the record"
    (line,) = [ln for ln in said(err) if stop in ln]
    assert "/imu0.linear_acceleration.x" in line and "(3 channels of /imu0)" in line
    assert "the others are searched again without them there" in line
    last = err.splitlines()[-1]
    assert "no sensor fault found (/imu0 has no reading after 48 s: see above)" in last
    # one statement, the same in findings.json and the report (beside the verdict too)
    assert [n for n in doc["notes"] if stop in n] == [line.removeprefix("analyzer: warning: ")]
    assert doc["faults"] == []
    text = _report_text(out)
    verdict = text[text.index("Read the verdict with these notes") :]
    assert stop in verdict[:2000]


def test_a_topic_that_starts_late_is_said(tmp_path, capsys):
    """Inside the healthy window (the first 20 % of the record): noted, and on stderr.
    (This record gets an offset on /s5 at 64.67 s on 49eb6ce too: the healthy window
    holds 12 s of /s3-/s5; not this case's business.)"""
    code, err, _, _ = run_to(tmp_path, capsys, _robot(tmp_path, 121.0, 12.0), "--jobs", "1")
    assert code in (0, 1), err
    late = "has no reading in its first 12 s of the record (inside the healthy window"
    lines = [ln for ln in said(err) if late in ln]
    assert [ln.split(" has ")[0] for ln in lines] == [
        f"analyzer: warning: /s{k}.data" for k in (3, 4, 5)
    ]
    assert "has no reading after" not in err.splitlines()[-1]  # (it runs to the end)

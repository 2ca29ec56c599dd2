"""Alarms the reported findings do not explain, where a user looks first: with a fault
found on s4 and two sensors faulty from one instant later (which the detectors, isolating
one fault at a time, attribute to no sensor), the run said "1 sensor fault found on 1
sensor" in its verdict, ``findings.json``'s faults and its last line, the other alarms
only in a note deep in the report. Now the verdict warns (sensors, when, what to run),
``findings.json`` has ``unexplained_alarms`` and the last line ends "alarms on ... not
explained: see the report"; a single fault and a healthy record get none of these."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest
from cli_helpers import run_cli
from jsonschema import Draft202012Validator

from analyzer.schema import findings_schema
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 100.0
WARNING = re.compile(r'<p class="unexplained"[^>]*>(.*?)</p>', re.S)


def _record(folder: Path, faults: list[tuple[int, float, float | None]]) -> Path:
    """A 6-floor building (one sensor a floor, 300 s, seed 1) with 2-sd offsets
    ``(sensor, onset s, end s or None)``, as a CSV of relative seconds."""
    t, y, names = simulate_building(6, 300.0, RATE, seed=1)
    for j, onset, end in faults:
        y[:, j] = inject_fault(y[:, j], RATE, "additive", onset, 2.0 * float(y[:, j].std()), end)
    path = folder / "building.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, i] for i, n in enumerate(names)}
    )
    return path


def _run(tmp_path: Path, capsys: pytest.CaptureFixture[str], faults: list) -> tuple:
    out = tmp_path / "o"
    code, _, err = run_cli(["run", _record(tmp_path, faults), "--out", out], capsys)
    doc = json.loads((out / "findings.json").read_text(encoding="utf-8"))
    html = (out / "report.html").read_text(encoding="utf-8")
    assert not list(Draft202012Validator(findings_schema()).iter_errors(doc))
    return code, err.splitlines()[-1], doc, html


def test_a_second_and_third_fault_left_unattributed_are_said_in_all_three_places(tmp_path, capsys):
    code, last, doc, html = _run(
        tmp_path, capsys, [(4, 70.0, 110.0), (1, 150.0, None), (2, 150.0, None)]
    )
    assert code == 1
    assert [f["channel"] for f in doc["faults"]] == ["s4"]  # s1, s2 missed
    (alarm,) = doc["unexplained_alarms"]
    assert {"s1", "s2"} <= set(alarm["channels"])
    assert abs(alarm["onset_s"] - 150.0) < 2.0 and alarm["onset"] is None
    assert len(alarm["detectors"]) >= 2 and alarm["beside"] == []
    assert last.startswith("analyzer: 1 sensor fault found on 1 sensor: s4 additive")
    assert re.search(
        r"; alarms not explained at 1[45]\d\.\d s, on (\d sensors|[^;]*s1[^;]*): see the report$",
        last,
    ), last
    # right under the verdict's headline, before the verdict's facts
    (warning,) = WARNING.findall(html)
    head = html.index('<p class="headline">')
    assert head < html.index('<p class="unexplained"') < html.index("Record start")
    assert "s1" in warning and "s2" in warning and "150.0 s" in warning
    assert "--channels &#39;!s0&#39;" in warning  # one of them, not the sensor found


@pytest.mark.parametrize("faults", [[(4, 70.0, 110.0)], []], ids=["one fault", "healthy"])
def test_a_single_fault_or_a_healthy_record_gets_no_warning(tmp_path, capsys, faults):
    code, last, doc, html = _run(tmp_path, capsys, faults)
    assert code == (1 if faults else 0)
    assert doc["unexplained_alarms"] == []
    assert "not explained" not in last
    assert not WARNING.findall(html)


def test_anomalies_with_no_finding_are_said_on_the_last_line(tmp_path, capsys):
    """Two sensors faulty from the same instant, no other fault: the detectors attribute
    the anomaly to no sensor and the run finds no fault (exit 0); its last line said
    nothing of it (the ux55 audit: stderr silent with anomalies on 8-12 of 16 sensors).
    Now it ends with when and on which sensors, briefly."""
    code, last, doc, _ = _run(tmp_path, capsys, [(1, 150.0, None), (2, 150.0, None)])
    assert code == 0 and doc["faults"] == []
    assert any(n.startswith("anomaly at ") for n in doc["notes"]), doc["notes"]
    assert last.startswith("analyzer: no sensor fault found; report: ")
    tail = re.search(
        r"; alarms not explained at (\d+ times from )?1[45]\d\.\d s, on ([^;]*): see the report$",
        last,
    )
    assert tail, last
    assert "s1" in tail[2] or "sensors" in tail[2]


def test_the_last_line_counts_many_alarms_and_sensors(tmp_path, capsys):
    """Alarms at several times on many sensors: one short tail (how many times, from
    when, how many sensors), not every channel set (536 characters in the audit)."""
    from analyzer.diagnosis.unexplained import Unexplained
    from analyzer.findings import Analysis
    from analyzer.pipeline import summary_line

    names = tuple(f"/data.data[{k}]" for k in range(16))
    unexplained = [
        Unexplained(names[k : k + 10], 3600.0 * (k + 1), ("ar_kalman_bank",), ()) for k in range(5)
    ]
    analysis = Analysis.__new__(Analysis)
    for key, value in {
        "findings": [_finding()],
        "unexplained": unexplained,
        "notes": [],
        "absolute_time": True,
        "start_ns": 1_780_272_000 * 10**9,
    }.items():
        object.__setattr__(analysis, key, value)
    line = summary_line(analysis, Path("out"))
    tail = line.split("; report: out/report.html")[1]
    assert tail == (
        "; alarms not explained at 5 times from 3600.0 s (2026-06-01T01:00:00.000Z), "
        "on 14 sensors: see the report"
    ), tail


def _finding():
    from analyzer.diagnosis import Finding
    from analyzer.types import FaultType

    return Finding("/data.data[5]", FaultType.ADDITIVE, 62400.0, None, {"offset": 4.3}, 0.99, "x")

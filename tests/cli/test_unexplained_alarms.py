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
    assert re.search(r"; alarms on [^;]*s1[^;]* not explained: see the report$", last), last
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

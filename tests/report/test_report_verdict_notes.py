"""A new user's audit of report.html: (1) on real records a wall of notes (batched log
times, channels left out, a training window that was not steady, detectors not run) came
before the findings, the one that changed how to read them among the rest; (2) a finding
of type "other" with rms 0.00085 read "> 99.9 %" with nothing to tell whether it
mattered. Now the verdict and the findings come first, the notes follow grouped by kind
(folded, with a count line), the ones that change how to read the findings stay beside
the verdict; and every finding has its size against its sensor's spread in the training
window (findings.json's ``size_relative``), with "statistically clear but small" where
a confident one is under a tenth of it."""

from __future__ import annotations

import dataclasses
import html as htmllib
import json
import re

import numpy as np
import pytest

import analyzer.report.view as report_view
from analyzer.cli import main
from analyzer.findings import findings_document, size_relative
from analyzer.report import render_report
from analyzer.report.format import SMALL_SIZE, relative_size
from analyzer.report.notes import OTHER, kind_of, sort_notes
from analyzer.report.synthetic import SyntheticFault, synthetic_analysis
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType

RATE = 100.0


def _record(path):
    """A 5-minute building (8 sensors) with a 3-sd step on s2 at 45 s, inside the given
    training window 0:60 (the window is then not steady: a note that changes how to read
    the findings), a 2-sd offset on s5 from 150 s (a finding), a constant channel and a
    counter (two notes of channels left out)."""
    t, y, names = simulate_building(4, 300.0, RATE, seed=14, sensors_per_floor=2)
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 45.0, 3.0 * y[:6000, 2].std())
    sd5 = y[:6000, 5].std()
    y[:, 5] = inject_fault(y[:, 5], RATE, "additive", 150.0, 2.0 * sd5)
    extra = np.column_stack([np.full(t.size, 7.0), np.arange(t.size, dtype=float)])
    header = "time," + ",".join(names) + ",const,counter"
    data = np.column_stack([t, y, extra])
    np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.9g")
    return path


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("notes")
    out = tmp / "o"
    code = main(["run", str(_record(tmp / "b.csv")), "--out", str(out), "--train", "0:60"])
    doc = json.loads((out / "findings.json").read_text())
    page = (out / "report.html").read_text()
    assert code == 1 and doc["faults"], "the offset on s5 must be found for these tests"
    assert any("is not steady" in n for n in doc["notes"]), "the window must not be steady"
    return doc, page


def _section(page: str, name: str) -> str:
    start = page.index(f'<section id="{name}">')
    ends = [
        i
        for s in ("findings", "notes", "archive", "models")
        if (i := page.find(f'<section id="{s}">', start + 1)) > 0
    ]
    return page[start : min(ends)]


def _text(fragment: str) -> str:
    return htmllib.unescape(re.sub(r"<[^>]+>", "", fragment))


def test_the_verdict_and_findings_come_before_the_notes(run):
    doc, page = run
    notes = page.index('<section id="notes">')
    assert page.index('<section id="verdict">') < page.index('<section id="findings">') < notes
    verdict = _text(_section(page, "verdict"))
    steady = next(n for n in doc["notes"] if "is not steady" in n)
    # the note that changes how to read the findings stays beside the verdict ...
    assert steady in verdict and "Read the findings with these notes" in verdict
    # ... the others do not: only a line that counts them all, by kind
    for n in doc["notes"]:
        if n != steady:
            assert n not in verdict
    assert "3 notes: 1 about the training window, 2 about which channels were analyzed" in verdict
    assert "the one shown above is among them" in verdict
    # folded by kind, without any script
    section = _section(page, "notes")
    assert section.count("<details") == 2 and "<script" not in page
    assert "About which channels were analyzed (2)" in section
    assert "About the training window (1)" in section


def test_no_note_is_lost(run):
    """Every note of findings.json, every input error and every detector not run is on
    the page, in the Notes section, once there."""
    doc, page = run
    section = _text(_section(page, "notes"))
    errors = [f"{i['path']}: {e}" for i in doc["inputs"] for e in i["errors"]]
    for n in [*doc["notes"], *errors]:
        assert section.count(n) == 1, n
    # a detector that runs only with a config says so in a line of its own
    for name, why in doc["skipped_detectors"].items():
        assert name in section and why in section, name
    text = _text(page)
    for d in doc["detectors"]:
        for n in d["notes"]:
            assert n in text, n


def test_every_note_lands_in_exactly_one_group():
    notes = [
        "constant or empty channels not analyzed: a, b",
        "the healthy window (0-60 s) is not steady: s2 changes inside it at about 45 s",
        "s0: 9,989 samples on only about 931 distinct log times at 10 Hz (written in batches)",
        "alarm on s2 at 16.150 s explained by the alarm on its assistant sensor(s) s4 (law 0)",
        "1 of 3 findings has a confidence below 0.05 (s1 at 3.0 s): weak evidence",
        "something no rule has heard of",
    ]
    sorted_ = sort_notes(notes, ["x.mcap: truncated"], {"error_function": "needs a config"})
    listed = [n for g in sorted_.groups for n in g.notes]
    assert sorted(listed) == sorted([*notes, "x.mcap: truncated", "needs a config"])
    assert kind_of(notes[-1]) == OTHER and sorted_.total == 8
    assert sorted_.key == [notes[1], notes[4]]
    assert sorted_.count.startswith("8 notes: 1 input error, 1 about the training window, ")


def test_a_caveat_about_a_channel_is_key_only_where_it_has_a_finding():
    note = "at most 4 distinct values in the training window: a finding on it may be rounding: s1"
    assert sort_notes([note], faulty={"s1"}).key == [note]
    assert sort_notes([note], faulty={"s10"}).key == []


def test_an_onset_at_the_search_start_is_said_beside_the_verdict(monkeypatch):
    monkeypatch.setattr(report_view, "MAX_DETAILED", 0)
    a = synthetic_analysis(120.0, 2, 50.0, [SyntheticFault(1, FaultType.ADDITIVE, 75.5, None, 1.0)])
    a.findings[0].evidence["onset_at_search_start"] = True
    page = render_report(a, findings_document(a))
    verdict = _text(_section(page, "verdict"))
    channel = a.analyzed[1]
    assert f"finding 1 ({channel}) was there when the search began at 75.50 s" in verdict


# -- the size against the sensor's spread ------------------------------------------------


def test_size_relative_in_findings_json_matches_the_injected_size(run):
    """The 2-sd offset on s5 (sd over the first 60 s): about 2 of its spread in the
    training window, and exactly the offset over that window's standard deviation."""
    doc, _ = run
    (f,) = [f for f in doc["faults"] if f["channel"] == "s5"]
    assert f["type"] == "additive"
    assert f["size_relative"] == pytest.approx(2.0, rel=0.1)


def test_size_relative_of_each_kind_of_magnitude():
    healthy = (3.0, 2.0)  # mean 3, sd 2
    assert size_relative({"offset": -5.0}, healthy, 10.0, None, 60.0) == 2.5
    assert size_relative({"offset": 0.1, "rms": 0.4}, healthy, 10.0, None, 60.0) == 0.2
    # a gain's change (a - 1) * y has RMS |a - 1| * sqrt(mean^2 + sd^2) over healthy readings
    assert size_relative({"gain": 1.5}, healthy, 10.0, None, 60.0) == pytest.approx(
        0.5 * np.hypot(3.0, 2.0) / 2.0, rel=1e-3
    )
    # a drift: the offset reached by its end (the record's end while it lasts)
    assert size_relative({"rate_per_s": 0.1}, healthy, 10.0, None, 60.0) == 2.5
    assert size_relative({"rate_per_s": -0.1}, healthy, 10.0, 30.0, 60.0) == 1.0
    # no size to measure, or no spread to measure it by
    assert size_relative({"clipped_high": 4.0}, healthy, 10.0, None, 60.0) is None
    assert size_relative({"offset": 1.0}, (3.0, 0.0), 10.0, None, 60.0) is None
    assert size_relative({"offset": 1.0}, None, 10.0, None, 60.0) is None


def test_a_confident_but_small_finding_says_so_in_the_verdict(monkeypatch):
    """An offset of 1 on a sensor whose healthy spread is 40: clear to the detectors,
    0.025 of the sensor's spread."""
    monkeypatch.setattr(report_view, "MAX_DETAILED", 1)
    a = synthetic_analysis(120.0, 2, 50.0, [SyntheticFault(1, FaultType.ADDITIVE, 75.5, None, 1.0)])
    a = dataclasses.replace(a, healthy={a.analyzed[0]: (0.0, 1.0), a.analyzed[1]: (0.0, 40.0)})
    doc = findings_document(a)
    (f,) = doc["faults"]
    assert f["confidence"] >= 0.95 and f["size_relative"] == pytest.approx(0.025, rel=0.01)
    page = render_report(a, doc)
    verdict = _text(_section(page, "verdict"))
    assert "statistically clear but small: 0.025 of the sensor's usual spread" in verdict
    finding = _text(_section(page, "findings"))
    assert "0.025 of the sensor's usual spread" in finding


def test_the_wording_of_sizes():
    assert relative_size(4.531, 1.0) == "4.53 × the sensor's usual spread"
    assert relative_size(0.4, 1.0) == "0.4 of the sensor's usual spread"
    assert relative_size(0.02, 0.9997).startswith("statistically clear but small: 0.02 of")
    assert relative_size(0.02, 0.3).startswith("small: 0.02 of")
    assert relative_size(SMALL_SIZE, 1.0) == "0.1 of the sensor's usual spread"
    assert relative_size(None, 1.0) == ""
    # never in exponent notation
    assert relative_size(0.0011838, 1.0).endswith(": 0.00118 of the sensor's usual spread")
    assert relative_size(1.2e-5, 1.0).endswith(": under 0.001 of the sensor's usual spread")
    assert relative_size(1234.4, 1.0) == "1234 × the sensor's usual spread"


def test_a_note_that_begins_with_a_channel_name_is_sorted_by_what_it_says():
    """A channel's name opens many notes and may be any word: SKAB's label column
    ``anomaly`` opened the note that left it out, which was sorted among the alarms'
    notes (``^anomaly``) instead of with the channels left out."""
    note = (
        "anomaly, changepoint hold only 0 and 1 over the record: flags or labels, not "
        "measurements; left out of the analysis; name them in --channels to analyze them"
    )
    assert kind_of(note) == "channels"

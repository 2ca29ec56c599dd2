"""How sure a finding is, in a word an engineer can act on (findings.json's
``evidence_label``, the report's evidence column), and a change of the whole structure's
response said beside the verdict, naming the findings it overlaps (the structural
engineer's audit ux60 item 3: the agreement score is not calibrated, and on SKAB's
anomaly-free record the note on a load change sat among the notes while the headline
counted 7 faults)."""

from __future__ import annotations

import json
import re
from html import unescape
from pathlib import Path

import numpy as np
import pytest

from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.report import render_report
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

SCHEMA = Path(__file__).resolve().parents[2] / "analyzer" / "schema" / "findings.schema.json"
SKAB_FREE = Path("/work/shared/realdata/benchmark/SKAB/data/anomaly-free/anomaly-free.csv")
RATE = 50.0


def _text(html: str) -> str:
    return " ".join(unescape(re.sub(r"<[^>]+>", " ", html)).split())


def _verdict(html: str) -> str:
    """The verdict section's text (the headline, the lines beside it, the table)."""
    return _text(html.split('<section id="verdict">')[1].split("</section>")[0])


def _analyzed(path: Path, t: np.ndarray, y: np.ndarray, names: list[str]):
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
    )
    analysis = analyze([path], RunOptions())
    return analysis, findings_document(analysis)


@pytest.fixture(scope="module")
def near_limit(tmp_path_factory):
    """A 4-floor building (300 s) whose s2 takes an offset of 0.06 of its spread at
    180 s: near the detection limit, where the audit saw findings on the wrong sensor
    score up to 1."""
    t, y, names = simulate_building(4, 300.0, RATE, seed=403)
    sd = float(np.std(y[: int(60 * RATE), 2]))
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 180.0, 0.06 * sd)
    return _analyzed(tmp_path_factory.mktemp("n") / "near.csv", t, y, names)


@pytest.fixture(scope="module")
def load_change(tmp_path_factory):
    """A 4-floor building (300 s) whose every response is 4 times larger from 200 to
    250 s (the load rose: a linear structure's response scales with it), with an offset
    of 2 sd on s1 from 150 s to the end, and the same record without the load change."""
    t, y0, names = simulate_building(4, 300.0, RATE, seed=7)
    sd = float(np.std(y0[: int(60 * RATE), 1]))
    y = y0.copy()
    y[int(200 * RATE) : int(250 * RATE)] *= 4.0
    steady, y = y0.copy(), y
    for z in (steady, y):
        z[:, 1] = inject_fault(z[:, 1], RATE, "additive", 150.0, 2.0 * sd)
    folder = tmp_path_factory.mktemp("l")
    return (
        _analyzed(folder / "load.csv", t, y, names),
        _analyzed(folder / "steady.csv", t, steady, names),
    )


def test_each_finding_has_a_label_and_why_in_findings_json(near_limit):
    _, doc = near_limit
    assert doc["faults"]
    for f in doc["faults"]:
        assert f["evidence_label"] in ("strong", "moderate", "weak")
        assert f["evidence_label_why"] and all(isinstance(w, str) for w in f["evidence_label_why"])
    jsonschema = pytest.importorskip("jsonschema")
    jsonschema.validate(json.loads(json.dumps(doc)), json.loads(SCHEMA.read_text()))


def test_near_limit_findings_are_weak_whatever_their_score(near_limit):
    """Every finding below a quarter of its sensor's spread, or seen by one detector, is
    weak, and the report's table says so in words."""
    analysis, doc = near_limit
    small = [
        f
        for f in doc["faults"]
        if (f["size_relative"] or 0) < 0.25 or len(f["evidence"]["detectors"]) == 1
    ]
    assert small
    assert all(f["evidence_label"] == "weak" for f in small)
    text = _text(render_report(analysis, doc))
    assert "evidence" in text.split("what to check")[0]
    assert "weak: confirm before sending anyone" in text


def test_a_clear_fault_is_strong_and_a_load_change_lowers_it(load_change):
    """The offset of 2 sd with a steady load: strong. The same offset where the whole
    structure's response rose 4-fold: its finding names the stretch and is one step
    lower, and the verdict says the finding may be that change."""
    (analysis, doc), (_, steady) = load_change
    clear = [f for f in steady["faults"] if f["channel"] == "s1"]
    assert clear and clear[0]["evidence_label"] == "strong", clear
    assert "level_change" not in clear[0]
    mine = [f for f in doc["faults"] if f["channel"] == "s1"]
    assert mine, doc["faults"]
    changed = mine[0].get("level_change")
    assert changed, doc["notes"]
    assert len(changed) == 1 and changed[0]["level"] >= 2.0
    assert abs(changed[0]["start_s"] - 200.0) <= 10.0 and abs(changed[0]["end_s"] - 250.0) <= 10.0
    assert mine[0]["evidence_label"] == "moderate"
    assert any("load or the structure changed" in w for w in mine[0]["evidence_label_why"])
    verdict = _verdict(render_report(analysis, doc))
    number = doc["faults"].index(mine[0]) + 1
    assert "The whole structure's response" in verdict
    assert re.search(rf"findings? [0-9, ]*\b{number}\b[0-9, ]* overlaps? it", verdict), verdict


def test_the_rule():
    """Each route to a wrong finding makes it weak; a large, agreed, tested one is
    strong; a load change lowers a label one step."""
    from analyzer.evidence_label import label_of

    assert label_of(3, 2.0, True, False, [])[0] == "strong"
    assert label_of(3, 0.5, True, False, [])[0] == "moderate"
    assert label_of(3, 2.0, None, False, [])[0] == "moderate"
    assert label_of(1, 2.0, True, False, [])[0] == "weak"
    assert label_of(3, 0.1, True, False, [])[0] == "weak"
    assert label_of(3, 2.0, False, False, [])[0] == "weak"
    assert label_of(3, 2.0, True, True, [])[0] == "weak"
    change = [{"start_s": 1.0, "end_s": 2.0, "level": 2.7}]
    assert label_of(3, 2.0, True, False, change)[0] == "moderate"
    assert label_of(3, 0.5, True, False, change)[0] == "weak"
    assert label_of(1, 2.0, True, False, change)[0] == "weak"


@pytest.mark.skipif(not SKAB_FREE.is_file(), reason="SKAB's anomaly-free.csv not present")
def test_skab_anomaly_free_load_change_beside_the_verdict(tmp_path):
    """SKAB's anomaly-free record (the audit's --train 0:1500): the findings in the
    stretches of the level note are named beside the headline, and none of them is
    strong."""
    analysis = analyze([SKAB_FREE], RunOptions(train="0:1500"))
    doc = findings_document(analysis)
    over = [i + 1 for i, f in enumerate(doc["faults"]) if f.get("level_change")]
    assert over, doc["notes"]
    assert all(doc["faults"][i - 1]["evidence_label"] != "strong" for i in over)
    verdict = _verdict(render_report(analysis, doc))
    assert "The whole structure's response" in verdict
    named = re.search(r"findings? ([0-9, ]+) overlaps?", verdict)
    assert named and [int(x) for x in named.group(1).split(",")] == over

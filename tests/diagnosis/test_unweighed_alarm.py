"""An alarm over a stretch whose residual has too few finite samples to weigh any fault
shape is no sensor's fault (``Classification.weighed``): the realdata audit found a
finding with confidence 0 and an offset of 0 after a gap, and exit 1 for it."""

from __future__ import annotations

import json

import numpy as np
from scipy.signal import lfilter

from analyzer.cli import main
from analyzer.diagnosis.changes import Calibration, calibrate
from analyzer.diagnosis.classify import classify
from analyzer.diagnosis.events import events_from_residual, unweighed_note


def test_a_residual_of_two_finite_samples_weighs_no_shape():
    fault = np.array([np.nan, 3.0, np.nan, 2.0, np.nan])
    cls = classify(fault, None, 1.0, 100.0)
    assert not cls.weighed
    assert classify(np.full(50, 3.0), None, 1.0, 100.0).weighed


def test_a_model_run_after_a_gap_is_no_fault_of_confidence_zero(tmp_path, realdata):
    skab = realdata / "benchmark" / "SKAB" / "data"
    model = tmp_path / "skab.model"
    base = ["--no-progress", "--out"]
    train = ["run", str(skab / "anomaly-free" / "anomaly-free.csv"), "--train", "0:2000"]
    main([*train, "--save-model", str(model), *base, str(tmp_path / "fit")])
    rc = main(
        ["run", str(skab / "valve1" / "2.csv"), "--model", str(model), *base, str(tmp_path / "o")]
    )
    doc = json.loads((tmp_path / "o" / "findings.json").read_text())
    assert all(f["confidence"] > 0 for f in doc["faults"]), doc["faults"]
    assert rc == (1 if doc["faults"] else 0)
    # the alarm stays a note: an anomaly that no sensor's fault explains
    assert any(n.startswith("anomaly at 600.0 s") for n in doc["notes"]), doc["notes"]
    # and the detection filter, whose alarm on Thermocouple there had too few finite
    # samples too, says so instead of dropping it without a word
    (filt,) = [d for d in doc["detectors"] if d["name"] == "detection_filter"]
    assert any(
        n.startswith("alarm on Thermocouple at 600.000 s not weighed") for n in filt["notes"]
    ), filt["notes"]


def _thin_alarm(n: int = 20_000, start: int = 6000) -> tuple[np.ndarray, Calibration]:
    """A healthy residual whose data ends at 100 s in two samples of 40 sd: an alarm over
    two finite samples, then the gap to the end."""
    e = np.random.default_rng(1).standard_normal(n)
    r = 0.05 * lfilter([1.0], [1.0, -0.6], e)
    cal = calibrate(r[:start], 25)
    r[10_000:] = np.nan
    r[10_002:10_004] = 40.0 * cal.std
    return r, cal


def test_the_shared_search_notes_an_alarm_too_thin_to_weigh():
    """The event search of the detection filter, the observers and the error functions
    (``events_from_residual``) left such an alarm out without a word; the AR bank notes
    its own. Now it is no event either, and a note names the channel, when, and why."""
    r, cal = _thin_alarm()
    notes: list[str] = []
    events = events_from_residual("s1", r, None, cal, 100.0, "test", search_start=6000, notes=notes)
    assert events == []
    assert notes == [
        "alarm on s1 at 100.020 s not weighed: fewer than 3 finite residual samples in the "
        "alarm (over a gap in the data, or the filters' warm-up after one), too few to fit "
        "any fault shape; not reported as a sensor fault"
    ]
    # without a list for them, the search is as it was: no event, nothing else
    assert events_from_residual("s1", r, None, cal, 100.0, "test", search_start=6000) == []


def test_the_note_names_a_few_alarms_and_counts_the_rest():
    note = unweighed_note("s2", [float(t) for t in range(7)])
    assert note.startswith("7 alarms on s2 at 0.000 s, 1.000 s, 2.000 s, 3.000 s, 4.000 s ")
    assert "and 2 more not weighed" in note

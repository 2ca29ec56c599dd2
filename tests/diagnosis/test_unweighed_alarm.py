"""An alarm over a stretch whose residual has too few finite samples to weigh any fault
shape is no sensor's fault (``Classification.weighed``): the realdata audit found a
finding with confidence 0 and an offset of 0 after a gap, and exit 1 for it."""

from __future__ import annotations

import json

import numpy as np

from analyzer.cli import main
from analyzer.diagnosis.classify import classify


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

"""The scoring of ``benchmarks/sweep_skab_labelled.py`` (SKAB's labelled records against
their labels): the labelled stretches, and each onset's kind, above all an onset at the
filters' warm-up end, which is no detected onset however close to the label (ux55 item
5: "600.000 s or earlier" equalled the labels by the records' design)."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pandas as pd

SCRIPT = Path(__file__).resolve().parent.parent / "benchmarks" / "sweep_skab_labelled.py"
_spec = importlib.util.spec_from_file_location("sweep_skab_labelled", SCRIPT)
assert _spec is not None and _spec.loader is not None
sweep = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(sweep)


def test_the_labelled_stretches_are_the_runs_of_ones_on_the_rows_own_times():
    stamps = pd.date_range("2020-03-09 10:00:00", periods=10, freq="s").delete([4])
    frame = pd.DataFrame(
        {"datetime": stamps.astype(str), "anomaly": [0, 1, 1, 0, 1, 1, 1, 0, 1]}
    )  # (the row of 4 s is missing)
    assert sweep.stretches(frame) == [(1.0, 2.0), (5.0, 7.0), (9.0, 9.0)]


def test_each_onset_is_warm_up_detected_before_or_outside():
    spans = [(600.0, 1000.0), (1100.0, 1110.0)]
    kind = sweep.kind_of
    # at the warm-up's end (599 s), a second later, or said present when the search
    # began: never detected, though 600 s is the label's start
    assert kind(599.0, False, 599.0, spans, 60.0) == "warm-up"
    assert kind(600.0, False, 599.0, spans, 60.0) == "warm-up"
    assert kind(700.0, True, 599.0, spans, 60.0) == "warm-up"
    assert kind(601.0, False, 599.0, spans, 60.0) == "detected"
    assert kind(1000.0, False, 599.0, spans, 60.0) == "detected"
    # a stretch shorter than the tolerance: up to 60 s after its start
    assert kind(1150.0, False, 599.0, spans, 60.0) == "detected"
    assert kind(1161.0, False, 599.0, spans, 60.0) == "outside"
    assert kind(1050.0, False, 599.0, spans, 60.0) == "outside"
    late_warm_up = 300.0
    assert kind(450.0, False, late_warm_up, spans, 60.0) == "before"

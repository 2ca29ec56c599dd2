"""Audit: two faults back to back on one sensor (a drift on s0 from 100 to 160 s of a
6-floor building, and a new drift from 160 to 220 s) gave one finding, 100-160 s; the
second was lost although every detector had found it. Its events joined the first's
finding (they touch within the merge's 1 s slack), or, in their own finding, were taken
through a floor partner's finding for the first drift, which was over."""

from __future__ import annotations

import pytest
from run_helpers import run_csv

from analyzer.detectors.base import Event
from analyzer.diagnosis import merge_events
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType

D = FaultType.DRIFT


def _drift(detector: str, onset: float, end: float | None) -> Event:
    return Event("s0", onset, end, D, {"rate_per_s": 0.066}, 1.0, detector, {})


def test_a_detectors_own_back_to_back_events_stay_two_findings():
    events = [
        _drift("equivalent_model", 100.048, 160.0),
        _drift("detection_filter", 100.062, 160.0),
        _drift("ar_kalman_bank", 100.212, 160.0),
        _drift("equivalent_model", 159.95, 220.0),
        _drift("detection_filter", 160.028, 220.0),
    ]
    first, second = merge_events(events)
    assert (first.onset_s, first.end_s) == (100.048, 160.0)
    assert second.onset_s == pytest.approx(159.95) and second.end_s == 220.0
    assert second.evidence["detectors"] == ["detection_filter", "equivalent_model"]


def test_stretches_of_one_fault_that_another_detector_saw_whole_stay_one_finding():
    events = [
        _drift("detection_filter", 100.0, 220.0),
        _drift("equivalent_model", 101.0, 130.0),
        _drift("equivalent_model", 130.5, 170.0),
        _drift("equivalent_model", 171.0, None),
    ]
    (f,) = merge_events(events)
    assert len(f.events) == 4


@pytest.mark.parametrize("seed", [1, 2])
def test_a_new_drift_where_one_ended_is_found_on_its_own(tmp_path, seed):
    t, y, names = simulate_building(6, 300.0, 100.0, seed=seed)
    rate = 0.05 * y[:, 0].std()
    y[:, 0] = inject_fault(y[:, 0], 100.0, "drift", 100.0, rate, 160.0)
    y[:, 0] = inject_fault(y[:, 0], 100.0, "drift", 160.0, rate, 220.0)
    faults = run_csv(tmp_path, t, y, names)
    # (seed 1 also gives a drift on s1 from 100 to 160 s, the first drift seen through
    # the detection filter's estimate of s1, with an unconfirmed bank offset there: a
    # known limit, benchmarks/README.md, sweep_changes.py)
    faults = [f for f in faults if f["channel"] == "s0"]
    spans = [(f["channel"], f["type"], f["onset_s"], f["end_s"]) for f in faults]
    assert len(spans) == 2, spans
    for (channel, kind, onset, end), (t0, t1) in zip(spans, [(100, 160), (160, 220)], strict=True):
        assert (channel, kind) == ("s0", "drift")
        assert abs(onset - t0) < 1.0 and abs(end - t1) < 1.0
    for f in faults:
        assert f["magnitude"]["rate_per_s"] == pytest.approx(rate, rel=0.05)

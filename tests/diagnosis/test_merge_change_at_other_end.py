"""A change a detector saw on one sensor where another sensor's fault ended is that
fault's trace leaving the residual, not this sensor's fault changing
(:func:`analyzer.diagnosis.merge._other_ended`). An offset on s0 from 100 to 200 s and
one on s3 from 150 to 250 s (6 floors, seed 3): the detection filter saw s3's fault
change at 200.13 s, where s0's ended, while the bank and the equivalent model saw it
whole to 250 s. Before, the filter's part up to the change led (s3 ended at 200.13 s,
offset 3.66 for 3.85 injected, s0's fault in its fit) and the part after it was dropped
as s0's doing (ux60 item 1)."""

from __future__ import annotations

import numpy as np

from analyzer.detectors.base import Event
from analyzer.diagnosis.merge import merge_events
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType
from analyzer.writers import write_archive

ADD = FaultType.ADDITIVE


def _ev(ch: str, det: str, on: float, end: float, size: float, changed: float | None = None):
    evidence = {} if changed is None else {"changed_at_s": changed}
    return Event(ch, on, end, ADD, {"offset": size}, 1.0, det, evidence)


def _s3_parts(s0_end: float) -> list[Event]:
    """The first search's events of the seed-3 record (sizes rounded), with the
    equivalent model's s0 event ending at ``s0_end``."""
    return [
        _ev("s0", "ar_kalman_bank", 100.0, 222.71, 2.64),
        _ev("s0", "detection_filter", 100.0, 222.71, 2.64),
        _ev("s0", "equivalent_model", 100.0, s0_end, 2.63),
        _ev("s3", "ar_kalman_bank", 150.0, 250.0, 3.91),
        _ev("s3", "detection_filter", 150.0, 200.13, 3.66, changed=150.0),
        _ev("s3", "equivalent_model", 150.0, 250.0, 3.85),
        _ev("s3", "detection_filter", 200.13, 250.0, 3.85, changed=200.13),
    ]


def test_change_where_another_sensors_fault_ended_keeps_one_finding():
    s3 = [f for f in merge_events(_s3_parts(200.0)) if f.channel == "s3"]
    assert len(s3) == 1
    assert (s3[0].onset_s, s3[0].end_s) == (150.0, 250.0)
    # the size of a detector that saw the whole stretch, not the part with s0's fault
    assert s3[0].magnitude["offset"] in (3.91, 3.85)
    assert len(s3[0].events) == 4


def test_change_of_the_sensors_own_fault_still_splits():
    # no fault of another sensor ended near 200.13 s: the filter saw s3's own change
    s3 = [f for f in merge_events(_s3_parts(260.0)) if f.channel == "s3"]
    assert [(f.onset_s, f.end_s) for f in s3] == [(150.0, 200.13), (200.13, 250.0)]


def test_overlapping_offsets_second_fault_reported_to_its_end(tmp_path):
    rate = 100.0
    t, y, names = simulate_building(6, 300.0, rate, seed=3)
    sd = y.std(axis=0)
    y[:, 0] = inject_fault(y[:, 0], rate, "additive", 100.0, 2.0 * sd[0], 200.0)
    y[:, 3] = inject_fault(y[:, 3], rate, "additive", 150.0, 2.0 * sd[3], 250.0)
    path = tmp_path / "two.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
    )
    work = tmp_path / "work"
    work.mkdir()
    a = analyze([str(path)], RunOptions(), work)
    got = {f.channel: f for f in a.findings}
    assert sorted(got) == ["s0", "s3"]
    assert abs(got["s0"].end_s - 200.0) <= 1.0
    assert got["s3"].end_s is not None and abs(got["s3"].end_s - 250.0) <= 1.0
    # within 2 % of the injected 2 sd (3.85): the part before 200 s read 3.66
    assert abs(got["s3"].magnitude["offset"] - 2.0 * sd[3]) <= 0.02 * 2.0 * sd[3]
    assert not any("not reported" in str(n) and "on s3" in str(n) for n in a.notes)

"""Audit: a fault whose level or type changes while it lasts was one finding with one
shape fitted over both parts: an offset of 3 sd that dropped to 1 sd was reported as
one offset of the average, to the record's end; one of 1 sd that rose to 3 sd as a
drift from 66 s (its onset 34 s before the fault's); a sign flip kept the first sign;
an offset followed by a gain was one offset. Each detector now ends a fault's shape
where one shape no longer holds and the level of what it leaves changes, and reports
the rest as a fault of its own from there (``diagnose_interval``'s ``changes``)."""

from __future__ import annotations

import numpy as np
import pytest
from run_helpers import run_csv
from scipy.signal import lfilter

from analyzer.detectors.base import Event
from analyzer.diagnosis import merge_events
from analyzer.diagnosis.changes import calibrate
from analyzer.diagnosis.events import events_from_residual
from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import FaultType

RATE = 100.0
N = 30_000


def _residual(seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    reference = lfilter([1.0], [1.0, -0.99], rng.standard_normal(N))
    return lfilter([1.0], [1.0, -0.5], rng.standard_normal(N)) * 0.3, reference


def _events(r: np.ndarray, reference: np.ndarray) -> list[tuple[str, float, float | None, dict]]:
    cal = calibrate(r[:6000], 25)
    found = events_from_residual(
        "c", r, reference, cal, RATE, "det", search_start=6000, healthy_start=0, split=True
    )
    return [
        (e.type.value, round(e.onset_s, 1), e.end_s and round(e.end_s, 1), e.magnitude)
        for e in found
    ]


@pytest.mark.parametrize("seed", [0, 1, 2])
@pytest.mark.parametrize(
    "steps",
    [
        [(10_000, 20_000, 3.0), (20_000, N, 1.0)],  # drops
        [(10_000, 20_000, 1.0), (20_000, N, 3.0)],  # rises
        [(10_000, 18_000, 2.0), (18_000, 26_000, -2.0)],  # flips sign, then ends
    ],
)
def test_a_level_that_changes_is_two_faults_each_with_its_size(seed, steps):
    r, reference = _residual(seed)
    for a, b, size in steps:
        r[a:b] += size
    found = _events(r, reference)
    assert len(found) == 2, found
    for (kind, onset, end, magnitude), (a, b, size) in zip(found, steps, strict=True):
        assert kind == "additive" and onset == a / RATE
        assert end == (None if b == N else b / RATE)
        assert magnitude["offset"] == pytest.approx(size, abs=0.05)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_one_level_and_one_drift_stay_one_fault_each(seed):
    r, reference = _residual(seed)
    offset = r.copy()
    offset[10_000:] += 2.0
    assert [k for k, *_ in _events(offset, reference)] == ["additive"]
    r[10_000:] += 0.0005 * np.arange(N - 10_000)
    ((kind, onset, end, magnitude),) = _events(r, reference)
    assert kind == "drift" and end is None and abs(onset - 100.0) < 1.0
    assert magnitude["rate_per_s"] == pytest.approx(0.05, rel=0.02)


def test_a_detector_that_saw_the_change_leads_the_findings():
    """Detectors that found the change lead: one that fitted one shape over both parts
    (the bank: an average offset to the end) does not."""
    A = FaultType.ADDITIVE

    def ev(detector, onset, end, offset, changed=None):
        evidence = {} if changed is None else {"changed_at_s": changed}
        return Event("s2", onset, end, A, {"offset": offset}, 1.0, detector, evidence)

    events = [
        ev("ar_kalman_bank", 100.0, None, 3.42),
        ev("detection_filter", 100.0, 200.0, 5.13),
        ev("equivalent_model", 100.0, 200.0, 5.13),
        ev("detection_filter", 200.0, None, 1.71, changed=200.0),
        ev("equivalent_model", 200.0, None, 1.71, changed=200.0),
    ]
    first, second = merge_events(events)
    assert (first.onset_s, first.end_s, first.magnitude["offset"]) == (100.0, 200.0, 5.13)
    assert first.evidence["detectors"] == ["ar_kalman_bank", "detection_filter", "equivalent_model"]
    assert (second.onset_s, second.end_s, second.magnitude["offset"]) == (200.0, None, 1.71)


@pytest.mark.parametrize(
    ("seed", "faults"),
    [
        (1, [("additive", 100.0, 200.0, 3.0), ("additive", 200.0, None, 1.0)]),
        (2, [("additive", 100.0, 160.0, 2.0), ("multiplicative", 160.0, 220.0, 1.8)]),
    ],
)
def test_a_fault_that_changes_is_reported_part_by_part(tmp_path, seed, faults):
    t, y, names = simulate_building(6, 300.0, RATE, seed=seed)
    sd = y[:, 3].std()
    for kind, onset, end, size in faults:
        y[:, 3] = inject_fault(
            y[:, 3], RATE, kind, onset, size * sd if kind == "additive" else size, end
        )
    got = run_csv(tmp_path, t, y, names)
    assert [(f["channel"], f["type"]) for f in got] == [("s3", k) for k, *_ in faults]
    for f, (kind, onset, end, size) in zip(got, faults, strict=True):
        assert abs(f["onset_s"] - onset) < 0.5
        assert (f["end_s"] is None) if end is None else abs(f["end_s"] - end) < 0.5
        want = size * sd if kind == "additive" else size
        key = "offset" if kind == "additive" else "gain"
        assert f["magnitude"][key] == pytest.approx(want, rel=0.03)


def test_an_offset_then_a_gain_that_no_half_of_the_stretch_separates(tmp_path):
    """An offset of 2 sd from 400 to 450 s and a gain of 1.8 from 450 to 520 s on s2 of
    an 8-floor building (an audit's case): the stretch 400-520 s fits no shape, its
    first half takes in 10 s of the gain and its first quarter is too short to stand
    for the fault, so every detector reported one ``other`` from 400 to 520 s. The
    level of the residual changes at 450 s: the part before it is the offset, and the
    rest the gain."""
    t, y, names = simulate_building(8, 600.0, RATE, seed=1)
    sd = y[:, 2].std()
    y[:, 2] = inject_fault(y[:, 2], RATE, "additive", 400.0, 2.0 * sd, 450.0)
    y[:, 2] = inject_fault(y[:, 2], RATE, "multiplicative", 450.0, 1.8, 520.0)
    got = run_csv(tmp_path, t, y, names)
    assert [(f["channel"], f["type"]) for f in got] == [
        ("s2", "additive"),
        ("s2", "multiplicative"),
    ]
    first, second = got
    assert abs(first["onset_s"] - 400.0) < 0.5 and abs(first["end_s"] - 450.0) < 0.5
    assert abs(second["onset_s"] - 450.0) < 0.5 and abs(second["end_s"] - 520.0) < 0.5
    assert first["magnitude"]["offset"] == pytest.approx(2.0 * sd, rel=0.05)
    assert second["magnitude"]["gain"] == pytest.approx(1.8, rel=0.03)


def test_the_part_after_a_change_is_sized_with_the_healthy_slope():
    """Review: without a healthy window of the record (``--model``), each fault's shape
    leaves out the residual's share of the reference measured before the fault; the part
    after a change measured it on the fault's own first part (a gain, then an offset of
    3.0 read 3.357)."""
    rng = np.random.default_rng(0)
    n = 40_000
    reference = lfilter([1.0], [1.0, -0.99], rng.standard_normal(n))
    r = lfilter([1.0], [1.0, -0.5], rng.standard_normal(n)) * 0.3
    r[10_000:20_000] += 0.5 * reference[10_000:20_000]
    r[20_000:] += 3.0
    cal = calibrate(r[:6000], 25)
    first, second = events_from_residual(
        "c", r, reference, cal, RATE, "det", search_start=6000, before_onset=True, split=True
    )
    assert first.type is FaultType.MULTIPLICATIVE and first.magnitude["gain"] == pytest.approx(
        1.5, abs=0.01
    )
    assert second.type is FaultType.ADDITIVE and second.onset_s == 200.0
    assert second.magnitude["offset"] == pytest.approx(3.0, abs=0.05)

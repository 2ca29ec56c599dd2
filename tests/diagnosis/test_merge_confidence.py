"""How merging combines confidences and which intervals it takes for one fault.

References, in closed form: the finding's confidence is ``1 - prod_d (1 - c_d)`` over the
detectors ``d`` that saw the fault, ``c_d`` the most confident of detector ``d``'s events
(independent detectors, each at its best; the docstring of ``merge_events``); two events
belong to one fault when the gap between their intervals is at most ``slack_s``, whichever
of the two comes first."""

from __future__ import annotations

import pytest

from analyzer.detectors.base import Event
from analyzer.diagnosis.merge import Finding, found_already, merge_events
from analyzer.types import FaultType

A = FaultType.ADDITIVE


def _ev(onset: float, end: float | None, conf: float, detector: str) -> Event:
    return Event("s1", onset, end, A, {"offset": 1.0}, conf, detector)


def test_confidence_takes_each_detectors_best_event():
    """The bank saw the fault twice (0.95 and 0.30), the equivalent model once (0.60):
    one finding, of confidence ``1 - (1 - 0.95)(1 - 0.60) = 0.98``; the bank's weaker
    second event neither lowers nor raises it."""
    events = [
        _ev(10.0, 20.0, 0.95, "ar_kalman"),
        _ev(12.0, 19.0, 0.30, "ar_kalman"),
        _ev(10.1, 20.0, 0.60, "equivalent_model"),
    ]
    (f,) = merge_events(events)
    assert f.confidence == pytest.approx(1.0 - (1.0 - 0.95) * (1.0 - 0.60), abs=1e-12)
    assert len(f.events) == 3


def _gap(a: tuple[float, float], b: tuple[float, float]) -> float:
    """Time between two intervals (negative when they overlap)."""
    return max(a[0], b[0]) - min(a[1], b[1])


@pytest.mark.parametrize(
    ("first", "second"),
    [((10.0, 12.0), (12.5, 15.0)), ((10.0, 12.0), (13.5, 15.0)), ((10.0, 12.0), (12.0, 15.0))],
)
def test_events_within_the_slack_of_each_other_are_one_finding(first, second):
    """Two detectors' events ``first`` and ``second`` (the second begins after the first
    ended) make one finding exactly when the gap between them is at most the 1 s slack:
    0.5 s and 0 s apart, one; 1.5 s apart, two."""
    slack = 1.0
    events = [_ev(*first, 0.9, "ar_kalman"), _ev(*second, 0.8, "equivalent_model")]
    findings = merge_events(events, slack_s=slack)
    assert len(findings) == (1 if _gap(first, second) <= slack else 2)


@pytest.mark.parametrize("later_first", [False, True])
@pytest.mark.parametrize(("gap", "expected"), [(0.5, True), (1.5, False)])
def test_found_already_tolerates_the_slack_on_either_side(later_first, gap, expected):
    """``found_already`` holds for a finding ``gap`` seconds before or after one already
    found when the gap is at most the 1 s slack: the same answer both ways round."""

    def finding(onset: float, end: float) -> Finding:
        return Finding("s1", A, onset, end, {}, 0.9, "ar_kalman")

    early, late = finding(10.0, 12.0), finding(12.0 + gap, 15.0)
    new, old = (late, early) if later_first else (early, late)
    assert found_already(new, [old], 1.0) is expected

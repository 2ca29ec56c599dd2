"""Merging the detectors' events into findings: one finding per physical fault, its type
voted by the detectors."""

from __future__ import annotations

import pytest

from analyzer.detectors.base import Event
from analyzer.diagnosis import merge_events
from analyzer.types import FaultType

A, D = FaultType.ADDITIVE, FaultType.DRIFT


def _ev(detector: str, kind: FaultType, conf: float, onset: float = 20.0) -> Event:
    mag = {"offset": 6.8} if kind is A else {"rate_per_s": -0.03}
    return Event("s4", onset, None, kind, {**mag, "by": len(detector)}, conf, detector)


def test_two_agreeing_detectors_outvote_one_more_confident():
    """A step on s4 and a later drift on another sensor: the detection filter reads s4 as
    a drift (its shape blurred by the second fault), the bank and the equivalent model as
    an offset: the finding is the offset, with the most confident additive event's
    magnitude, and every detector as evidence."""
    events = [
        _ev("ar_kalman_bank", A, 0.9),
        _ev("detection_filter", D, 0.99, 20.1),
        _ev("equivalent_model", A, 0.8),
    ]
    (f,) = merge_events(events)
    assert f.type is A and f.detector == "ar_kalman_bank" and "offset" in f.magnitude
    assert f.evidence["detectors"] == ["ar_kalman_bank", "detection_filter", "equivalent_model"]
    assert f.confidence == pytest.approx(1 - 0.1 * 0.01 * 0.2)


def test_a_detector_votes_once_and_ties_go_to_the_most_confident_event():
    events = [
        _ev("ar_kalman_bank", A, 0.6),
        _ev("ar_kalman_bank", A, 0.5, 20.5),
        _ev("detection_filter", D, 0.95),
    ]
    (f,) = merge_events(events)
    assert f.type is D  # 0.95 against the bank's best 0.6 (its events do not add up)
    (f,) = merge_events([_ev("ar_kalman_bank", A, 0.7), _ev("detection_filter", D, 0.7)])
    assert f.type is A and f.confidence == pytest.approx(1 - 0.3 * 0.3)  # the first of equals

"""Diagnosis: from residuals to faults (when, what type, how large, how sure)."""

from analyzer.diagnosis.changes import (
    Calibration,
    Interval,
    alarm_statistic,
    calibrate,
    change_point,
    default_window,
    detect,
    detection_confidence,
)
from analyzer.diagnosis.classify import Classification, classify, correlation_time
from analyzer.diagnosis.merge import (
    Finding,
    ends_hidden_by_later,
    ends_of_later_faults,
    merge_events,
    one_fault_at_a_time,
    onsets_hidden_by_earlier,
)

__all__ = [
    "Calibration",
    "Classification",
    "Finding",
    "Interval",
    "alarm_statistic",
    "calibrate",
    "change_point",
    "classify",
    "correlation_time",
    "default_window",
    "detect",
    "detection_confidence",
    "ends_hidden_by_later",
    "ends_of_later_faults",
    "merge_events",
    "one_fault_at_a_time",
    "onsets_hidden_by_earlier",
]

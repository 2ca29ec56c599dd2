"""Alarms the reported findings do not explain (``analyzer.diagnosis.unexplained``): with
two faulty sensors a run may report one and leave the other's alarms "attributed to no
sensor"; before this, only the run's notes said so, and the verdict, ``findings.json``'s
faults and the run's last line read "one faulty sensor"."""

from __future__ import annotations

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.levels import Excursion
from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.unexplained import Unexplained, and_joined, unexplained_alarms
from analyzer.types import FaultType

SLACK = 2.0


def result(detector, unattributed):
    return DetectorResult(detector, ("s0", "s1", "s2", "s3"), {}, [], {}, unattributed=unattributed)


def finding(channel, onset, end=None):
    return Finding(channel, FaultType.ADDITIVE, onset, end, {"offset": 1.0}, 1.0, "x")


PAIR = [
    result("ar_kalman_bank", [(300.0, ("s1", "s2"), ())]),
    result("detection_filter", [(301.5, ("s2",), ())]),
]
"""An anomaly two detectors left unattributed at 300 s on s1 and s2."""


def test_an_anomaly_no_finding_explains_beside_a_found_fault_is_reported():
    found = [finding("s0", 100.0, 150.0)]  # over well before the anomaly
    assert unexplained_alarms(PAIR, found, SLACK) == [
        Unexplained(("s1", "s2"), 300.0, ("ar_kalman_bank", "detection_filter"), ())
    ]


def test_without_a_finding_nothing_is_reported_the_notes_say_it():
    # "no sensor fault found": a change of the load as often as several sensors at once
    assert unexplained_alarms(PAIR, [], SLACK) == []


def test_a_finding_under_way_on_its_sensor_or_lasting_or_echoed_explains_it():
    assert unexplained_alarms(PAIR, [finding("s2", 299.0)], SLACK) == []  # its own sensor
    # a fault lasting from before: "a second fault, or that one's doing" (the note's words)
    assert unexplained_alarms(PAIR, [finding("s0", 100.0)], SLACK) == []
    assert unexplained_alarms(PAIR, [finding("s0", 100.0, 301.0)], SLACK) == []  # ends there
    assert unexplained_alarms(PAIR, [finding("s0", 300.5)], SLACK) == []  # begins there


def test_one_detector_alone_is_not_reported():
    alone = [result("ar_kalman_bank", [(300.0, ("s1", "s2"), ())])]
    assert unexplained_alarms(alone, [finding("s0", 100.0, 150.0)], SLACK) == []


def test_an_anomaly_where_the_load_left_the_training_range_is_not_reported():
    found = [finding("s0", 100.0, 150.0)]
    burst = [Excursion(290.0, 340.0, 10.0)]
    assert unexplained_alarms(PAIR, found, SLACK, burst) == []
    later = [Excursion(500.0, 540.0, 10.0)]
    assert len(unexplained_alarms(PAIR, found, SLACK, later)) == 1


def test_the_equivalent_models_second_fault_is_reported_unless_one_of_them_was_found():
    em = [
        result(
            "equivalent_model",
            [(720.1, ("s1", "s2"), ("s3",)), (721.0, ("s1", "s2"), ("s3",))],
        )
    ]
    found = [finding("s3", 720.0)]
    assert unexplained_alarms(em, found, SLACK) == [
        Unexplained(("s1", "s2"), 720.1, ("equivalent_model",), ("s3",))
    ]
    assert unexplained_alarms(em, [*found, finding("s2", 720.0)], SLACK) == []


def test_sensors_are_named_once_each_set():
    assert and_joined(["s1"]) == "s1"
    assert and_joined(["s4", "s5"]) == "s4 and s5"
    assert and_joined(["s0", "s1", "s2"]) == "s0, s1 and s2"

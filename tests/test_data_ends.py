"""A finding's end where its channel stops publishing (the ux52 audit, item 9): ORB-SLAM's
pose in ``ROS_example.bag`` stops at 740.406 s of 889 s, and its drift's ``end_s`` was
740.4063, which reads as a recovery. Such a finding has no end (``end_s`` null: it lasts
to the end of its channel's data) and says where the data ends
(``evidence.data_ends_s``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from _realdata import realdata_or_skip

from analyzer.diagnosis.merge import Finding
from analyzer.types import FaultType

RATE = 10.0


def _finding(channel: str, end_s: float | None) -> Finding:
    return Finding(channel, FaultType.DRIFT, 5.0, end_s, {"rate_per_s": 0.1}, 0.9, "x")


def test_an_end_at_the_channels_last_reading_is_no_end() -> None:
    """``b`` has no reading from row 600 (60 s) of 1000: a finding that ends within one
    long alarm window (at 10 Hz, 8 windows of 16 rows: 12.8 s) of it has no end and
    ``data_ends_s`` 60; one that ends long before keeps its end; on ``a``, which runs to
    the record's end, an end just before it is kept (a recovery the data shows)."""
    from analyzer.data_ends import ends_with_data
    from analyzer.diagnosis.readings import shortest

    window = shortest(RATE)
    values = np.ones((1000, 2))
    values[600:, 1] = np.nan
    at_end = _finding("b", (599 - window + 1) / RATE)
    before = _finding("b", (599 - window - 5) / RATE)
    near_record_end = _finding("a", 990 / RATE)
    ends_with_data([at_end, before, near_record_end], values, ["a", "b"], RATE)
    assert at_end.end_s is None and at_end.evidence == {"data_ends_s": 60.0}
    assert before.end_s == (599 - window - 5) / RATE and "data_ends_s" not in before.evidence
    assert near_record_end.end_s == 99.0 and near_record_end.evidence == {}


def test_size_of_a_drift_to_the_end_of_its_data() -> None:
    """A drift without an end is sized to where its data ends, not the record's end."""
    from analyzer.data_ends import data_end
    from analyzer.findings import size_relative

    ends = data_end({"data_ends_s": 60.0})
    assert ends == 60.0 and data_end({}) is None
    assert size_relative({"rate_per_s": 0.1}, (0.0, 1.0), 10.0, ends, 100.0) == 5.0


def _realdata() -> Path:
    return realdata_or_skip("ros1/evo/ROS_example.bag")


@pytest.mark.realdata
def test_ros_example_audit_run(tmp_path: Path) -> None:
    """The audit's command (``run ROS_example.bag --train 20:300``): no fault on the
    ground truth's orientation.y (the quaternion's sign flips), and ORB-SLAM's drift,
    under way where ORB-SLAM stops publishing, without an end."""
    from analyzer.findings import findings_document
    from analyzer.options import RunOptions
    from analyzer.pipeline import analyze

    analysis = analyze([_realdata()], RunOptions(train="20:300"), tmp_path)
    faults = findings_document(analysis)["faults"]
    assert not [f for f in faults if f["channel"] == "groundtruth.pose.orientation.y"]
    (drift,) = [f for f in faults if f["channel"] == "ORB-SLAM.pose.position.z"]
    assert drift["end_s"] is None and drift["end"] is None
    assert drift["evidence"]["data_ends_s"] == pytest.approx(740.406, abs=0.001)
    assert any(
        "groundtruth.pose.orientation.{x,y,z,w}: 13 sign changes" in n for n in analysis.notes
    )

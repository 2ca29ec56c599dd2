"""Findings that end where their channel's data ends.

A channel that stops publishing before the record ends (ORB-SLAM's pose in
``ROS_example.bag`` stops at 740.406 s of 889.028 s) leaves nothing for the detectors to
see after its last reading: a fault under way there ends, for them, where the data
ends, and ``end_s: 740.4063`` read as a recovery (the ux52 audit). The contract's
``end_s`` is null "when the fault lasts to the end": to the end of its channel's data
here, which is all that is known. :func:`ends_with_data` writes such a finding's end as
null and keeps where the data ends in ``evidence.data_ends_s``, which the report shows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy.typing as npt

from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.readings import shortest
from analyzer.reconfigure import last_rows
from analyzer.timeutil import json_time


def ends_with_data(
    findings: Sequence[Finding], values: npt.NDArray[Any], chosen: Sequence[str], rate_hz: float
) -> None:
    """Set ``end_s`` to None, and ``evidence.data_ends_s`` to the time from which its
    channel has no reading, for each finding that ends within one long alarm window
    (:func:`~analyzer.diagnosis.readings.shortest`: the detectors' longest) of its
    channel's last reading, where that reading is more than such a window before the
    record's last one (the channel stopped, the others went on; a fault that ends shortly
    before the record does, on a channel that runs to it, keeps its end)."""
    ending = [f for f in findings if f.end_s is not None and f.channel in chosen]
    if not ending or not rate_hz > 0:
        return
    last = last_rows(values)
    if not bool((last >= 0).any()):
        return
    record = int(last.max())
    window = shortest(rate_hz)
    index = {name: j for j, name in enumerate(chosen)}
    for f in ending:
        row = int(last[index[f.channel]])
        if row < 0 or record - row <= window or f.end_s is None:
            continue
        if f.end_s * rate_hz >= row - window:
            # (the first row without a reading: the time the run's note on the channel
            # gives, "no reading in its last ... s (after 740.406 s)")
            f.evidence["data_ends_s"] = json_time((row + 1) / rate_hz)
            f.end_s = None


def data_end(evidence: dict[str, Any] | None) -> float | None:
    """Where a finding's channel's data ends (``evidence.data_ends_s``), or None."""
    value = (evidence or {}).get("data_ends_s")
    return None if value is None else float(value)


__all__ = ["data_end", "ends_with_data"]

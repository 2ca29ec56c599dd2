"""Durations in the notes a user reads are spoken (``30 min``), not ``{x:.3g}`` in
seconds (``1.8e+03 s``, as a new user's audit saw them on long records): the common-change
note's slow level (:func:`analyzer.diagnosis.common_mode.common_note`)."""

from __future__ import annotations

from analyzer.diagnosis.common_mode import CommonChange, common_note
from analyzer.diagnosis.merge import Finding
from analyzer.types import FaultType


def test_the_common_change_note_speaks_its_slow_level():
    changes = [
        CommonChange(
            finding=Finding(c, FaultType.DRIFT, 7200.0, None, {}, 0.8, "ar_kalman_bank"),
            shared=("s0", "s1", "s2"),
            group=("s0", "s1", "s2", "s3"),
            spread=(4.2, 9.5),
            critical=3.1,
            explained=2,
            block_s=1800.0,
        )
        for c in ("s0", "s1")
    ]
    note = common_note(changes)
    assert "Each such sensor's slow level (30 min means, in units of" in note
    assert "e+" not in note
    # the numbers themselves are as they were
    assert "(|t| 4.2 to 9.5, bound 3.1)" in note

"""Durations in the notes a user reads are spoken (``21 min``), not ``{x:.3g}`` in
seconds (``1.23e+03 s``, as a new user's audit saw them on long records): the error
functions' note on alarms of a whole group of uncertain sensors."""

from __future__ import annotations

from types import SimpleNamespace

from analyzer.detectors.base import Event
from analyzer.detectors.error_function import _all_at_once
from analyzer.types import FaultType


def test_the_group_alarm_note_speaks_its_span():
    functions = [
        SimpleNamespace(channel=c, group="deck", channels=(c, "r0", "r1")) for c in ("u0", "u1")
    ]
    events = [
        Event(c, onset, None, FaultType.OTHER, {}, 0.9, "error_function")
        for c, onset in (("u0", 5000.0), ("u1", 5600.0))
    ]
    notes: list[str] = []
    unattributed: list = []
    kept = _all_at_once(events, functions, 1234.0, notes, unattributed)  # type: ignore[arg-type]
    assert kept == [] and unattributed == [(5000.0, ("u0", "u1"), ())]
    (note,) = notes
    assert "beginning within 21 min and ending together" in note
    assert "e+" not in note

"""Times and spans read alike in every line (a maintainer's audit, ux61 items M1, M2):
:func:`analyzer.timeutil.seconds_text` promised that every line rounds a time as the
report and the ISO times do (half up: 300.0625 s is ``300.063``), but the merge notes,
the silence note and ``inspect``'s lines wrote ``{x:.3f}`` (``300.062``); and six
functions said a span six ways (100 s as ``100 s``, ``2 min`` or ``100.0 s``)."""

from __future__ import annotations

import numpy as np

from analyzer.diagnosis.merge import Finding, present_at_search_start
from analyzer.readers.base import ChannelChunk
from analyzer.silence_note import silence_note
from analyzer.store import ChannelStore
from analyzer.timeutil import seconds_text, spoken_duration
from analyzer.types import FaultType

ONSET = 300.0625
"""A sample time at 16 Hz, halfway between two milliseconds."""


def test_seconds_text_rounds_half_up_where_format_rounds_half_to_even():
    assert seconds_text(ONSET) == "300.063" and f"{ONSET:.3f}" == "300.062"


def test_a_merge_note_says_a_time_as_the_report_does():
    f = Finding("s1", FaultType.ADDITIVE, ONSET, None, {"offset": 1.0}, 0.9, "ar_kalman_bank")
    (note,) = present_at_search_start([f], ONSET, 16.0)
    assert "present when the search started at 300.063 s" in note, note


def test_the_silence_note_says_its_times_as_the_report_does(tmp_path):
    """A 16 Hz channel silent from 300.0625 s (its last sample) to 400 s."""
    t = np.arange(0, 16 * 600, dtype=np.int64) * 62_500_000  # 600 s at 16 Hz
    keep = (t <= int(ONSET * 1e9)) | (t >= 400 * 10**9)
    chunks = [
        ChannelChunk("a", t[keep], np.ones(int(keep.sum()))),
        ChannelChunk("b", t, np.ones(t.size)),
    ]
    with ChannelStore.from_chunks(chunks, tmp_path) as store:
        (note,) = silence_note(store, ["a", "b"], (), 0, 600.0)
    assert "a: no sample from 300.063 to 400.000 s" in note, note
    assert "while b went on" in note


def test_one_way_to_say_a_span():
    """The watcher's progress, the readers' clock lines and the store's lines all say a
    span by :func:`spoken_duration` (the watcher had ``2 min`` for 100 s, the readers
    ``100.0 s`` and ``2.3 days``, the store ``3.2 h`` and ``29.7 days``)."""
    from analyzer.readers._common import two_clocks

    assert [spoken_duration(x) for x in (100.0, 150.0, 5400.0, 200_000.0)] == [
        "100 s",
        "2.5 min",
        "90 min",
        "2.3 days",
    ]
    # (its unit by the number as written: a 2 h step measured a hair short is no "120 min",
    # nor 999.7 ms "1e+03 ms")
    assert spoken_duration(7199.98) == "2.0 h" and spoken_duration(0.9997) == "1.0 s"
    day = 86_400 * 10**9
    start = 1_700_000_000 * 10**9
    line = two_clocks(
        {"/imu": "header", "/tf": "log"},
        {"/imu": (start - 3 * day, start - 3 * day + 10**9), "/tf": (start, start + 10**9)},
    )
    assert "3.0 days before the others" in line, line

"""Which clipped or stuck values :func:`analyzer.missing_codes.code_hints` names as a
possible missing-value code: a usual code, or a value far outside the channel's other
readings; never a sensor's real limit at the edge of its readings (ux55 item 6)."""

from __future__ import annotations

import numpy as np

from analyzer.diagnosis import Finding
from analyzer.missing_codes import code_hints
from analyzer.types import FaultType


def _finding(channel, magnitude):
    return Finding(channel, FaultType.OTHER, 1.0, None, magnitude, 0.9, "x", evidence={})


def test_a_value_far_outside_is_hinted_a_real_limit_is_not():
    """-6999 (no usual code) far outside readings of about +-1 is hinted; a sensor
    clipping at its largest reading (1.0) is not."""
    col = np.sin(np.linspace(0, 60, 3000))
    far = col.copy()
    far[100:150] = -6999.0
    clipped = np.minimum(col, 0.8)
    values = np.column_stack([far, clipped])
    hints = code_hints(
        [_finding("a", {"stuck_at": -6999.0}), _finding("b", {"clipped_high": 0.8})],
        values,
        ["a", "b"],
    )
    assert len(hints) == 1 and hints[0].startswith("a: its stuck level -6999 is far outside")

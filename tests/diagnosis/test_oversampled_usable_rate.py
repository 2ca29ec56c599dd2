"""The oversampling note names a rate only where the run can analyze the training window
at it (ux52: ``rosbag2_test`` with ``--train 0:29`` was told ``--rate 5``, where the window
holds 146 of the 683 rows the detectors need, and the README said no real record gets it).
"""

from __future__ import annotations

import numpy as np

from analyzer.diagnosis.changes import default_window, training_need
from analyzer.diagnosis.oversampled import oversampled_note


def _sines(hz: float, rate: float, seconds: float) -> np.ndarray:
    """Three channels of a ``hz`` sine, a little noise on each, at ``rate``."""
    t = np.arange(int(seconds * rate)) / rate
    rng = np.random.default_rng(3)
    return np.column_stack(
        [np.sin(2 * np.pi * hz * t + k) + 0.01 * rng.standard_normal(t.size) for k in range(3)]
    )


def test_a_rate_the_training_window_is_too_short_at_is_not_named():
    # rosbag2_test's shape: 0.17-Hz sines at 25 Hz, a 29-s training window
    rate = 25.0
    y = _sines(0.17, rate, 29.0)
    assert training_need(default_window(5.0)) > 29.0 * 5.0  # (--rate 5 would be refused)
    assert oversampled_note(y, ["a", "b", "c"], (0, y.shape[0]), rate) is None
    # the same sines over a window long enough at 5 Hz: the note, naming --rate 5
    y = _sines(0.17, rate, 200.0)
    note = oversampled_note(y, ["a", "b", "c"], (0, y.shape[0]), rate)
    assert note is not None and "--rate 5 " in note


def test_the_usable_rate_is_the_slowest_round_one_the_window_suffices_at():
    from analyzer.diagnosis.oversampled import usable_rate  # (new: the base has none)

    need = training_need(default_window(20.0))  # (683 rows at the least window)
    assert usable_rate(20.0, 200.0, need / 20.0) == 20.0
    # a shorter window: 25 Hz is not enough either, 50 Hz is
    window = need / 50.0 + 0.1
    assert window * 25.0 < need
    assert usable_rate(20.0, 200.0, window) == 50.0
    # none up to the limit: no rate to name
    assert usable_rate(20.0, 40.0, window) is None

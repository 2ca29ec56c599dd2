"""A fault that ends shortly before the record does is given its end; one that lasts to
the record's last sample has none (it had not ended when the record stopped).

Reference: where the simulated offset stops, ``n - 60`` samples, known by construction."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.diagnosis import calibrate, detect

N = 10_000


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_a_fault_ending_60_samples_before_the_record_end_has_that_end(seed):
    """A 2 sd offset on white noise from sample 7000 to ``n - 60``, windows of 5 and 40
    samples (the long window's alarms stop some 20 samples before the record's end): one
    interval, from 7000 to ``n - 60`` within 2 samples, not open-ended. Taking an alarm
    run that stopped within 50 samples of the end as lasting to it reported no end."""
    r = np.random.default_rng(seed).normal(size=N)
    r[7000 : N - 60] += 2.0
    cal = calibrate(r[:3000], 5)
    (iv,) = detect(r, cal, search_start=3000)
    assert iv.onset == pytest.approx(7000, abs=2)
    assert iv.end is not None
    assert iv.end == pytest.approx(N - 60, abs=2)


def test_a_fault_lasting_to_the_record_end_has_no_end():
    """The same offset kept to the last sample: the interval is open (end None)."""
    r = np.random.default_rng(1).normal(size=N)
    r[7000:] += 2.0
    cal = calibrate(r[:3000], 5)
    (iv,) = detect(r, cal, search_start=3000)
    assert iv.onset == pytest.approx(7000, abs=2)
    assert iv.end is None

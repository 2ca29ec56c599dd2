"""A fault whose stretch a later change blurs is classified by its leading part
(:func:`analyzer.diagnosis.events._shaped_lead`)."""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

from analyzer.diagnosis.changes import calibrate
from analyzer.diagnosis.events import events_from_residual
from analyzer.types import FaultType

RATE = 100.0


def _record(seed: int, erratic_from: int | None):
    """A reference that varies (two tones), a coloured healthy residual, a gain of 1.3
    from 120 s to the end and, from ``erratic_from`` on, an erratic disturbance of
    another fault's making (bursts of noise that come and go)."""
    rng = np.random.default_rng(seed)
    n = 60_000
    t = np.arange(n) / RATE
    y = 3.0 * np.sin(2 * np.pi * 0.7 * t) + 2.0 * np.sin(2 * np.pi * 1.9 * t + 1.0)
    r = lfilter([0.3], [1.0, -0.5], rng.standard_normal(n))
    r[12_000:] += 0.3 * y[12_000:]
    if erratic_from is not None:
        bursts = (np.sin(2 * np.pi * 0.05 * t) > 0.3).astype(float)
        r[erratic_from:] += (3.0 * bursts * rng.standard_normal(n))[erratic_from:]
    return r, y


def _events(r, y):
    cal = calibrate(r[:6000], 25)
    return events_from_residual("s0", r, y, cal, RATE, "test", search_start=6000, healthy_start=0)


def test_a_gain_blurred_later_is_classified_by_its_beginning():
    r, y = _record(0, erratic_from=36_000)
    first = _events(r, y)[0]
    assert first.type is FaultType.MULTIPLICATIVE
    assert abs(first.magnitude["gain"] - 1.3) < 0.02
    assert abs(first.onset_s - 120.0) < 0.5


def test_an_erratic_fault_from_its_onset_stays_other():
    r, y = _record(1, erratic_from=None)
    r[:] = r - np.where(np.arange(r.shape[0]) >= 12_000, 0.3 * y, 0.0)  # no gain
    t = np.arange(r.shape[0]) / RATE
    bursts = (np.sin(2 * np.pi * 0.05 * t) > 0.3).astype(float)
    rng = np.random.default_rng(2)
    r[12_000:] += (3.0 * bursts * rng.standard_normal(r.shape[0]))[12_000:]
    found = _events(r, y)
    assert found and all(e.type is FaultType.OTHER for e in found)

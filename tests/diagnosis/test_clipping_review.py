"""Review probes of :func:`analyzer.diagnosis.clipping.merge_clipped`: what it must not
merge away."""

import numpy as np

from analyzer.diagnosis.clipping import find_clipping, merge_clipped
from analyzer.diagnosis.merge import Finding
from analyzer.types import FaultType

RATE = 100.0
N = 60_000
TRAIN = (0, 12_000)
ONSET = 36_000


def _two_channels(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(N) / RATE
    y = np.sin(2 * np.pi * 1.0 * t) + 0.5 * np.sin(2 * np.pi * 2.7 * t)
    return np.column_stack(
        [y + 0.2 * rng.standard_normal(N), np.roll(y, 7) + 0.2 * rng.standard_normal(N)]
    )


def _finding(channel, onset, end, detector="detection_filter", kind=FaultType.MULTIPLICATIVE):
    return Finding(
        channel, kind, onset, end, {"gain": 0.8}, 0.9, detector, {"detectors": [detector]}
    )


def test_a_fault_that_begins_after_the_clipping_ended_is_its_own():
    """s0 clips for 20 s (a stronger response, 360-380 s) and recovers; an offset on it
    from 500 s is a fault of its own, and the clipping ends with its last reading."""
    Y = _two_channels()
    lim = 1.05 * float(np.max(np.abs(Y[:, 0])))  # above every reading outside the stretch
    Y[ONSET : ONSET + 2000, 0] = np.clip(3.0 * Y[ONSET : ONSET + 2000, 0], -lim, lim)
    clip = find_clipping(Y, 0, TRAIN[1], TRAIN)
    assert clip is not None and clip.last < ONSET + 2000
    swarm = [_finding("s0", 361.0 + 4 * k, 361.5 + 4 * k) for k in range(4)]
    later = _finding("s0", 500.0, None, "ar_kalman_bank", FaultType.ADDITIVE)
    out, _ = merge_clipped([*swarm, later], Y, ["s0", "s1"], RATE, TRAIN, [("s0", "s1")])
    assert later in out
    (merged,) = [f for f in out if "clipped" in f.evidence]
    assert merged.evidence["clipped"]["findings_merged"] == 4
    assert merged.end_s is not None and merged.end_s < 400.0


def test_two_sensors_that_clip_at_once_are_two_findings():
    """Both channels of a group clip from 360 s: neither's swarm is the other's echo."""
    Y = _two_channels()
    Y[ONSET:] = np.clip(Y[ONSET:], -1.0, 1.0)
    sw0 = [_finding("s0", 361.0 + 10 * k, 361.5 + 10 * k) for k in range(5)]
    sw1 = [_finding("s1", 362.0 + 10 * k, 362.4 + 10 * k) for k in range(5)]
    out, notes = merge_clipped([*sw0, *sw1], Y, ["s0", "s1"], RATE, TRAIN, [("s0", "s1")])
    assert sorted(f.channel for f in out) == ["s0", "s1"]
    assert all("clipped" in f.evidence for f in out)
    assert not any("taken for that fault" in n for n in notes)


def test_an_offset_on_a_partner_is_its_own():
    """s0 clips from 360 s to the end; s1 has an offset from 400 s to 550 s that all three
    detectors report: before, it was taken for the clipping's echo (a clipped reading is
    within 4 s of almost any moment). A gain or an ``other`` there, short or long, one
    detector's or two, still is: what a cut peak leaves in a partner's residual."""
    Y = _two_channels()
    Y[ONSET:, 0] = np.clip(Y[ONSET:, 0], -1.0, 1.0)
    swarm = [_finding("s0", 361.0 + 10 * k, 361.5 + 10 * k) for k in range(5)]
    three = ["ar_kalman_bank", "detection_filter", "equivalent_model"]
    offset = _finding("s1", 400.0, 550.0, "ar_kalman_bank", FaultType.ADDITIVE)
    offset.evidence["detectors"] = three
    short = _finding("s1", 420.0, 421.0, "ar_kalman_bank")
    short.evidence["detectors"] = three[:2]
    lone = _finding("s1", 450.0, 480.0, "detection_filter", FaultType.OTHER)
    out, _ = merge_clipped(
        [*swarm, offset, short, lone], Y, ["s0", "s1"], RATE, TRAIN, [("s0", "s1")]
    )
    assert offset in out and short not in out and lone not in out

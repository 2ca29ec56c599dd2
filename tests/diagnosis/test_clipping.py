"""A sensor that clips (saturates): told by the pile-up of its readings at its limits,
its swarm of short findings reported as one (:mod:`analyzer.diagnosis.clipping`)."""

import numpy as np
import pytest

from analyzer.diagnosis.clipping import find_clipping, merge_clipped
from analyzer.diagnosis.merge import Finding
from analyzer.pipeline import RunOptions, analyze, findings_document
from analyzer.report import render_report
from analyzer.simulate import simulate_building
from analyzer.types import FaultType
from analyzer.writers import write_archive

RATE = 100.0
N = 60_000
TRAIN = (0, 12_000)
ONSET = 36_000


def _signal(seed: int = 0) -> np.ndarray:
    """A continuous reading: two sines and noise, one column of a 2-column record."""
    rng = np.random.default_rng(seed)
    t = np.arange(N) / RATE
    y = np.sin(2 * np.pi * 1.0 * t) + 0.5 * np.sin(2 * np.pi * 2.7 * t)
    return np.column_stack([y + 0.2 * rng.standard_normal(N), rng.standard_normal(N)])


def test_a_clipped_reading_piles_up_at_its_limits():
    Y = _signal()
    lim = 1.0
    Y[ONSET:, 0] = np.clip(Y[ONSET:, 0], -lim, lim)
    clip = find_clipping(Y, 0, TRAIN[1], TRAIN)
    assert clip is not None
    assert clip.high == lim and clip.low == -lim
    first = ONSET + int(np.argmax(np.abs(Y[ONSET:, 0]) >= lim))
    assert clip.first == first
    at = np.abs(Y[ONSET:, 0]) >= lim
    assert clip.count == int(at.sum())
    assert 0.0 < clip.fraction < 0.5


def test_one_side_only():
    Y = _signal()
    Y[ONSET:, 0] = np.minimum(Y[ONSET:, 0], 1.2)
    clip = find_clipping(Y, 0, TRAIN[1], TRAIN)
    assert clip is not None and clip.high == 1.2 and clip.low is None


@pytest.mark.parametrize(
    "make",
    [
        lambda y: y,  # continuous: every value read once
        lambda y: np.round(y, 1),  # quantized: its tail thins out at the extremes
        lambda y: np.where(np.arange(N) >= ONSET, 0.7, y),  # frozen: the stuck sensor's
    ],
    ids=["continuous", "quantized", "frozen"],
)
def test_no_clipping(make):
    Y = _signal()
    Y[:, 0] = make(Y[:, 0])
    assert find_clipping(Y, 0, TRAIN[1], TRAIN) is None


def test_a_limit_the_healthy_window_piles_up_at_too_is_clipping_from_there():
    """Clipped from the first reading (a range too small for the response): found, and
    where it began in the healthy window said."""
    Y = _signal()
    Y[3000:, 0] = np.clip(Y[3000:, 0], -1.0, 1.0)
    clip = find_clipping(Y, 0, TRAIN[1], TRAIN)
    assert clip is not None and clip.high == 1.0 and clip.low == -1.0
    assert clip.healthy_from == 3000 + int(np.argmax(np.abs(Y[3000:, 0]) >= 1.0))
    Y = _signal()
    Y[ONSET:, 0] = np.clip(Y[ONSET:, 0], -1.0, 1.0)
    found = find_clipping(Y, 0, TRAIN[1], TRAIN)
    assert found is not None and found.healthy_from is None


def _finding(channel, onset, end, detector="detection_filter", kind=FaultType.MULTIPLICATIVE):
    return Finding(
        channel, kind, onset, end, {"gain": 0.8}, 0.9, detector, {"detectors": [detector]}
    )


def test_the_swarm_is_one_finding_and_its_echo_on_a_partner_is_taken_for_it():
    Y = _signal()
    Y[ONSET:, 0] = np.clip(Y[ONSET:, 0], -1.0, 1.0)
    t0 = ONSET / RATE
    swarm = [_finding("s0", t0 + 1.0 + 10 * k, t0 + 1.5 + 10 * k) for k in range(5)]
    partner = _finding("s1", t0 + 11.0, t0 + 11.4, "ar_kalman_bank")
    lasting = _finding("s1", t0 + 20.0, None, "ar_kalman_bank", FaultType.ADDITIVE)
    out, notes = merge_clipped(
        [*swarm, partner, lasting], Y, ["s0", "s1"], RATE, TRAIN, [("s0", "s1")]
    )
    (merged,) = [f for f in out if f.channel == "s0"]
    assert merged.type is FaultType.OTHER
    assert merged.magnitude["clipped_high"] == 1.0 and merged.magnitude["clipped_low"] == -1.0
    assert merged.onset_s <= t0 + 1.0 and merged.end_s is None
    assert merged.evidence["clipped"]["findings_merged"] == 5
    assert [f for f in out if f.channel == "s1"] == [lasting]  # its own fault stays
    assert any("clips at 1 and -1" in n for n in notes)
    assert any("taken for that fault" in n and "s1" in n for n in notes)


def _clipped_building(tmp_path, on: int):
    """A 6-channel building (20 minutes, seed 2) whose s2 clips at half its peak from row
    ``on``, written as CSV and analyzed with the defaults: ``(Y, limit, analysis)``."""
    t, Y, _ = simulate_building(3, 1200.0, RATE, seed=2, sensors_per_floor=2)
    lim = 0.5 * float(np.max(np.abs(Y[:, 2])))
    Y[on:, 2] = np.clip(Y[on:, 2], -lim, lim)
    path = tmp_path / "clipped.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {f"s{i}": Y[:, i] for i in range(Y.shape[1])})
    return Y, lim, analyze([str(path)], RunOptions())


@pytest.mark.parametrize("start_s", [0.0, 120.0])
def test_a_sensor_that_clips_from_inside_the_healthy_window_is_one_finding(tmp_path, start_s):
    """s2 of a 6-channel building clipped at half its peak from the record's start or
    from 120 s (inside the default healthy window, 0-240 s): before, 22 and 37 findings
    (21 and 37 on s2); now one, whose evidence and note say it clipped in the healthy
    window already."""
    on = int(start_s * RATE)
    Y, lim, analysis = _clipped_building(tmp_path, on)
    assert [(f.channel, f.type) for f in analysis.findings] == [("s2", FaultType.OTHER)]
    clipped = analysis.findings[0].evidence["clipped"]
    first = (on + int(np.argmax(np.abs(Y[on:, 2]) >= lim))) / RATE
    assert clipped["in_healthy_window_from_s"] == pytest.approx(first)
    assert any("in the healthy window already" in n for n in analysis.notes)


def test_a_clipping_sensor_of_a_building_is_one_finding(tmp_path):
    """A 6-channel building whose s2 clips at half its peak from 60 % of a 20-minute
    record: before, 18 findings on s2 (gains below 1 where the peaks were cut, ``other``);
    now one, with its limits."""
    on = int(0.6 * 1200.0 * RATE)
    Y, lim, analysis = _clipped_building(tmp_path, on)
    assert [(f.channel, f.type) for f in analysis.findings] == [("s2", FaultType.OTHER)]
    (f,) = analysis.findings
    assert f.magnitude["clipped_high"] == pytest.approx(lim)
    assert f.magnitude["clipped_low"] == pytest.approx(-lim)
    first = (on + int(np.argmax(np.abs(Y[on:, 2]) >= lim))) / RATE
    assert abs(f.onset_s - first) < 0.05
    assert f.end_s is None
    # the report draws the limits on the finding's signal (text stays text in its SVGs)
    html = render_report(analysis, findings_document(analysis))
    assert html.count("clipping limit") == 1
    assert "dotted grey: the limits its readings pile up at" in html


def test_a_quantized_reading_that_clips():
    """Readings in steps of 0.01 (an ADC's counts, say) clipped at 1.7: the limit is read
    less often than values near the middle of the range, and still found."""
    Y = _signal()
    Y[:, 0] = np.round(Y[:, 0], 2)
    Y[ONSET:, 0] = np.minimum(Y[ONSET:, 0], 1.7)
    uniq, counts = np.unique(Y[TRAIN[1] :, 0], return_counts=True)
    assert counts[uniq == 1.7][0] < np.sort(counts)[-2]  # not among the two most frequent
    clip = find_clipping(Y, 0, TRAIN[1], TRAIN)
    assert clip is not None and clip.high == 1.7 and clip.low is None


def test_coarse_readings_are_not_judged():
    """Seven levels a standard deviation apart (SKAB's pump pressure), an offset moving
    them up after the healthy window: the shifted top level is read more often than the
    unshifted level below it, but that is no clipping."""
    rng = np.random.default_rng(3)
    levels = np.array([-0.6, -0.27, 0.05, 0.38, 0.71, 1.04])
    y = rng.choice(levels, N, p=[0.02, 0.12, 0.5, 0.3, 0.055, 0.005])
    y[ONSET:] += 0.25
    Y = np.column_stack([y, rng.standard_normal(N)])
    assert find_clipping(Y, 0, TRAIN[1], TRAIN) is None


def test_a_fault_that_began_before_the_clipping_is_its_own():
    Y = _signal()
    Y[ONSET:, 0] = np.clip(Y[ONSET:, 0], -1.0, 1.0)
    t0 = ONSET / RATE
    earlier = _finding("s0", t0 - 100.0, None, "ar_kalman_bank", FaultType.ADDITIVE)
    swarm = [_finding("s0", t0 + 1.0 + 10 * k, t0 + 1.5 + 10 * k) for k in range(3)]
    out, _ = merge_clipped([earlier, *swarm], Y, ["s0", "s1"], RATE, TRAIN, [("s0", "s1")])
    assert earlier in out
    (merged,) = [f for f in out if "clipped" in f.evidence]
    assert merged.evidence["clipped"]["findings_merged"] == 3


def test_a_partner_finding_cut_short_by_the_records_end_is_taken_for_it():
    """A 4-channel building whose s1 clipped: the bank and the detection filter put an
    ``other`` on s0 from 2 s before the record's end, open (``sweep_clipping.py --floors
    2``, seed 7). Within the window it takes to tell, it is the clipping's echo; one
    that began earlier and lasts to the end is its own."""
    Y = _signal()
    Y[ONSET:, 0] = np.clip(Y[ONSET:, 0], -1.0, 1.0)
    end = N / RATE
    swarm = [_finding("s0", ONSET / RATE + 1.0, ONSET / RATE + 1.5)]
    late = _finding("s1", end - 2.0, None, "ar_kalman_bank", FaultType.OTHER)
    lasting = _finding("s1", end - 60.0, None, "ar_kalman_bank", FaultType.ADDITIVE)
    out, notes = merge_clipped(
        [*swarm, late, lasting], Y, ["s0", "s1"], RATE, TRAIN, [("s0", "s1")]
    )
    assert late not in out and lasting in out


# review probes (what merge_clipped must not merge away)


def _two_channels(seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    t = np.arange(N) / RATE
    y = np.sin(2 * np.pi * 1.0 * t) + 0.5 * np.sin(2 * np.pi * 2.7 * t)
    return np.column_stack(
        [y + 0.2 * rng.standard_normal(N), np.roll(y, 7) + 0.2 * rng.standard_normal(N)]
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

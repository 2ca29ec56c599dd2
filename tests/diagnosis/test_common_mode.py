"""A slow change common to most sensors of a group (``analyzer.diagnosis.common_mode``):
a drift of every channel of a simulated building by one standard deviation over ten
minutes was reported as a drift of one sensor, found by two detectors. Now such a
finding is dropped with a note; one sensor's drift or offset, on a steady building or
on top of the common change, and two sensors' faults at once, stay."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from analyzer.diagnosis.common_mode import (
    MIN_SHARED,
    CommonNote,
    SlowLevels,
    common_changes,
    judge,
)
from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.training_check import window_warnings
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import simulate_building
from analyzer.types import FaultType

RATE = 100.0
SECONDS = 300.0
TRAIN = (0, int(0.2 * SECONDS * RATE))


def building(floors: int, seed: int, seconds: float = SECONDS) -> tuple[np.ndarray, list[str]]:
    _, y, names = simulate_building(floors, seconds, RATE, seed=seed, sensors_per_floor=2)
    return y, names


def common_drift(y: np.ndarray, sd: float, coef: np.ndarray | None = None) -> np.ndarray:
    """Every channel plus a line from 0 to ``sd`` of its training standard deviations
    over the record (times ``coef`` per channel: strain gauges)."""
    scale = y[TRAIN[0] : TRAIN[1]].std(axis=0) * (1.0 if coef is None else coef)
    return y + np.outer(np.linspace(0.0, sd, y.shape[0]), scale)


def finding(channel: str, kind: FaultType, onset_s: float, end_s: float | None = None) -> Finding:
    return Finding(channel, kind, onset_s, end_s, {}, 0.99, "ar_kalman_bank")


def run(y: np.ndarray, names: list[str], *found: Finding) -> tuple[list[Finding], list[str]]:
    return common_changes(list(found), y, names, [names], TRAIN, RATE)


@pytest.mark.parametrize(("floors", "seed"), [(2, 0), (3, 1), (8, 2)])
@pytest.mark.parametrize("kind", [FaultType.DRIFT, FaultType.ADDITIVE])
def test_a_drift_of_every_channel_is_no_sensors_fault(floors, seed, kind):
    y, names = building(floors, seed)
    y = common_drift(y, 1.0)
    f = finding("s2", kind, 0.25 * SECONDS if kind is FaultType.DRIFT else 0.7 * SECONDS)
    kept, notes = run(y, names, f)
    assert kept == []
    (note,) = notes
    assert isinstance(note, CommonNote)
    assert f"common to {len(names)} of {len(names)} sensors" in note
    assert f"the {kind.value} fault on s2" in note
    assert window_warnings(notes) == [note.short]  # repeated on stderr by `analyzer run`


def test_a_common_drift_with_a_coefficient_per_channel_is_no_sensors_fault():
    y, names = building(3, 3)
    coef = np.random.default_rng(3).uniform(0.5, 1.5, len(names))
    kept, notes = run(common_drift(y, 2.0, coef), names, finding("s4", FaultType.DRIFT, 80.0))
    assert kept == [] and len(notes) == 1


@pytest.mark.parametrize(("floors", "seed"), [(2, 4), (3, 5), (8, 6)])
@pytest.mark.parametrize("kind", [FaultType.DRIFT, FaultType.ADDITIVE])
def test_one_sensors_fault_on_a_steady_building_stays(floors, seed, kind):
    y, names = building(floors, seed)
    sd = y[TRAIN[0] : TRAIN[1], 1].std()
    onset = 0.5 * SECONDS
    if kind is FaultType.DRIFT:
        y[int(onset * RATE) :, 1] += sd * np.arange(y.shape[0] - int(onset * RATE)) / 60.0
    else:
        y[int(onset * RATE) :, 1] += sd
    f = finding("s1", kind, onset)
    assert run(y, names, f) == ([f], [])


@pytest.mark.parametrize("seed", range(4))
def test_one_sensors_offset_on_top_of_a_common_drift_stays(seed):
    # the control of benchmarks/sweep_eov.py --fault --cases thermal: 2 sd from 60 %
    y, names = building(3, seed)
    y = common_drift(y, 1.0)
    k = seed % len(names)
    y[int(0.6 * y.shape[0]) :, k] += 2.0 * y[TRAIN[0] : TRAIN[1], k].std()
    f = finding(names[k], FaultType.ADDITIVE, 0.6 * SECONDS)
    assert run(y, names, f) == ([f], [])


@pytest.mark.parametrize("seed", range(3))
def test_an_offset_on_a_drifting_building_reported_as_an_earlier_drift_stays(seed):
    # sweep_eov --fault --cases thermal, 6 ch seed 2: the offset of s5 from 365 s was
    # reported as a drift from 220 s, a shape the common trend explains; its step does not
    y, names = building(3, seed)
    y = common_drift(y, 1.0)
    k = (seed + 2) % len(names)
    y[int(0.6 * y.shape[0]) :, k] += 2.0 * y[TRAIN[0] : TRAIN[1], k].std()
    f = finding(names[k], FaultType.DRIFT, 0.35 * SECONDS)
    assert run(y, names, f) == ([f], [])


def test_another_sensors_fault_does_not_hide_a_common_change():
    # thermalgain --fault, 4 ch seed 4: s1's offset from 365 s made the others' median
    # trace step, and the false drift of s2 stayed; most single channels explain s2
    y, names = building(2, 4)
    y = common_drift(y, 2.0, np.random.default_rng(4).uniform(0.5, 1.5, len(names)))
    y[int(0.6 * y.shape[0]) :, 1] += 2.0 * y[TRAIN[0] : TRAIN[1], 1].std()
    false = finding("s2", FaultType.DRIFT, 0.2 * SECONDS)
    real = finding("s1", FaultType.ADDITIVE, 0.6 * SECONDS)
    kept, notes = run(y, names, false, real)
    assert kept == [real] and len(notes) == 1


def test_two_sensors_offsets_at_once_are_not_most_of_the_group():
    y, names = building(3, 7)
    at = int(0.6 * y.shape[0])
    for k in (1, 4):
        y[at:, k] += 2.0 * y[TRAIN[0] : TRAIN[1], k].std()
    found = [finding(names[k], FaultType.ADDITIVE, 0.6 * SECONDS) for k in (1, 4)]
    assert run(y, names, *found) == (found, [])


def test_a_gain_change_or_a_small_group_is_not_judged():
    y, names = building(3, 8)
    y = common_drift(y, 3.0)
    gain = finding("s0", FaultType.MULTIPLICATIVE, 100.0)
    assert run(y, names, gain) == ([gain], [])
    pair = names[:2]
    drift = finding("s0", FaultType.DRIFT, 100.0)
    assert common_changes([drift], y[:, :2], pair, [pair], TRAIN, RATE) == ([drift], [])
    assert MIN_SHARED == 3


def test_the_slow_levels_are_in_units_of_the_healthy_scatter():
    y, names = building(3, 9, seconds=600.0)
    train = (0, int(120 * RATE))
    levels = SlowLevels.build(y, range(len(names)), train, RATE)
    assert levels is not None
    assert levels.trained == 24 and levels.rows == 500  # the training window's 24 batches
    window = levels.y[: levels.trained]
    np.testing.assert_allclose(window.mean(axis=0), 0.0, atol=1e-9)
    # after the window a steady building's slow level scatters as in it
    after = levels.y[levels.trained :]
    assert np.all(np.abs(after.std(axis=0) - 1.0) < 0.5)
    # on a steady building a shape is significant on a channel about as often as its level
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(200):
        onset = rng.uniform(130.0, 500.0)
        kind = FaultType.DRIFT if rng.random() < 0.5 else FaultType.ADDITIVE
        t = levels.matched(levels.shape(finding("s0", kind, onset)))
        hits += int(np.sum(np.abs(t) >= levels.critical()))
    assert hits / (200 * len(names)) < 0.05  # COMMON_ALPHA is 0.01


def test_a_window_too_short_is_not_judged():
    y, names = building(2, 10, seconds=20.0)
    assert SlowLevels.build(y, range(4), (0, 100), RATE) is None
    f = finding("s0", FaultType.DRIFT, 10.0)
    assert common_changes([f], y, names, [names], (0, 100), RATE) == ([f], [])


def test_the_note_pickles_with_its_short_form():
    y, names = building(2, 11)
    _, (note,) = run(common_drift(y, 3.0), names, finding("s3", FaultType.ADDITIVE, 200.0))
    again = pickle.loads(pickle.dumps(note))
    assert again == note and again.short == note.short


def test_judge_names_the_sharing_channels_and_the_bound():
    y, names = building(3, 12)
    y = common_drift(y, 3.0)
    levels = SlowLevels.build(y, range(len(names)), TRAIN, RATE)
    assert levels is not None
    verdict = judge(finding("s5", FaultType.DRIFT, 90.0), 5, levels, names)
    assert verdict is not None
    assert verdict.shared == tuple(names)
    assert verdict.spread[0] >= verdict.critical
    assert verdict.explained > (len(names) - 1) / 2  # most others explain s5's level


def test_a_run_on_a_building_that_warms_reports_no_fault_but_the_change(tmp_path):
    # benchmarks/sweep_eov.py's `thermal` case: every channel drifts by 1 sd over 10
    # minutes; cedf93c reported a drift of s2 from 149.5 s (the equivalent model)
    t, y, names = simulate_building(3, 600.0, RATE, seed=0, sensors_per_floor=2)
    y = y + np.outer(t / t[-1], y[: int(120 * RATE)].std(axis=0))
    path = tmp_path / "warming.csv"
    rows = np.column_stack([t, y])
    np.savetxt(path, rows, delimiter=",", header="time," + ",".join(names), comments="")
    analysis = analyze([path], RunOptions())
    assert analysis.findings == []
    (note,) = [n for n in analysis.notes if isinstance(n, CommonNote)]
    assert note.startswith("a slow change common to 6 of 6 sensors")
    assert window_warnings(analysis.notes) == [note.short]  # `analyzer run`: on stderr

"""Frozen sensors: stuck at a value (``other``) or dead at zero (multiplicative, gain 0),
told from the readings over the fault whatever shape the residual took."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.detectors.base import DetectorResult
from analyzer.diagnosis.merge import Finding
from analyzer.diagnosis.stuck import (
    dead_unattributed,
    healthy_stats,
    relabel_frozen,
    revived_gains,
)
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import simulate_building
from analyzer.types import FaultType
from analyzer.writers import write_archive

RATE = 200.0


def _finding(channel: str, kind: FaultType, onset: float) -> Finding:
    return Finding(channel, kind, onset, None, {"offset": 1.0}, 0.9, "ar_kalman_bank")


def test_frozen_readings_are_relabelled_and_others_kept():
    rng = np.random.default_rng(0)
    n = 4000
    values = rng.standard_normal((n, 4))
    values[2000:, 0] = 2.5  # stuck
    values[2000:, 1] = 0.0  # dead
    values[2000:, 2] += 3.0  # a real offset: keeps its type
    values[2000:, 3] = 0.0
    values[2000::7, 3] = np.nan  # dead with gaps: gaps are ignored
    found = [
        _finding("a", FaultType.ADDITIVE, 10.0),
        _finding("b", FaultType.OTHER, 10.0),
        _finding("c", FaultType.ADDITIVE, 10.0),
        _finding("d", FaultType.DRIFT, 10.0),
    ]
    notes = relabel_frozen(found, values, ["a", "b", "c", "d"], RATE, (0, 1000))
    assert found[0].type is FaultType.OTHER
    assert found[0].magnitude["stuck_at"] == pytest.approx(2.5)
    assert found[1].type is FaultType.MULTIPLICATIVE and found[1].magnitude == {"gain": 0.0}
    assert found[2].type is FaultType.ADDITIVE and "frozen" not in found[2].evidence
    assert found[3].type is FaultType.MULTIPLICATIVE
    assert len(notes) == 3 and "stuck at 2.5" in notes[0]


@pytest.mark.parametrize("level", ["onset", "zero"])
def test_pipeline_reports_a_stuck_sensor_as_other_and_a_dead_one_as_gain_zero(tmp_path, level):
    t, Y, names = simulate_building(n_floors=4, duration_s=60.0, seed=3)
    k0 = int(30.0 * RATE)
    Y[k0:, 2] = Y[k0, 2] + 1.0 if level == "onset" else 0.0
    path = tmp_path / "frozen.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: Y[:, j] for j, n in enumerate(names)}
    )
    analysis = analyze([path], RunOptions())
    (f,) = [f for f in analysis.findings if f.channel == names[2]]
    assert f.onset_s == pytest.approx(30.0, abs=0.2)
    if level == "onset":
        assert f.type is FaultType.OTHER and f.magnitude["stuck_at"] == pytest.approx(Y[k0, 2])
    else:
        assert f.type is FaultType.MULTIPLICATIVE and f.magnitude["gain"] == 0.0


def test_readings_over_a_fault_are_read_in_pieces(tmp_path, monkeypatch):
    """One channel's readings over a fault come from a memory-mapped matrix a piece of
    rows at a time, each piece given back: the column itself, NaNs included."""
    from analyzer import paging

    rng = np.random.default_rng(2)
    values = rng.standard_normal((10_000, 3))
    values[4_000:4_010, 1] = np.nan
    mapped = paging.mapped_file(tmp_path / "m.npy", values.shape, np.float64)
    mapped[:] = values
    released = []
    monkeypatch.setattr(paging, "RELEASE_ROWS", 999)
    monkeypatch.setattr(paging, "release", lambda a: released.append(a.shape[0]))
    got = paging.read_column(mapped, 1, 123, 9_876)
    np.testing.assert_array_equal(got, values[123:9_876, 1])
    assert sum(released) == 9_876 - 123 and max(released) == 999
    assert paging.read_column(values, 2, 5, 5).shape == (0,)


def test_a_frozen_finding_starts_where_its_readings_froze():
    """The detectors alarm on a dead sensor when the structure moves, seconds after it
    died: the finding starts where the readings froze, traced back no further than the
    search's start; gaps inside the frozen stretch do not end it, and a reading that
    moved does."""
    rng = np.random.default_rng(1)
    values = rng.standard_normal((6000, 3))
    values[3000:, 0] = 0.0  # dead from row 3000, alarmed at row 3500
    values[3200:3300, 0] = np.nan
    values[2500:, 1] = 1.75 + 1e-4 * rng.standard_normal(3500)  # stuck, with a little noise
    values[:, 2] = 0.0  # frozen from the start: traced back to the search's start only
    found = [
        _finding("a", FaultType.MULTIPLICATIVE, 3500 / RATE),
        _finding("b", FaultType.ADDITIVE, 2600 / RATE),
        _finding("c", FaultType.ADDITIVE, 2000 / RATE),
    ]
    values[:1000, 2] = rng.standard_normal(1000)  # (its healthy window moved)
    notes = relabel_frozen(found, values, ["a", "b", "c"], RATE, (0, 1000), search_start=1200)
    assert [f.onset_s for f in found] == [3000 / RATE, 2500 / RATE, 1200 / RATE]
    assert found[0].evidence["frozen"]["since_s"] == 15.0
    assert found[0].evidence["frozen"]["alarmed_from_s"] == 17.5
    assert "the detectors saw it from 17.500 s: it starts where they froze" in notes[0]
    # already from where it froze: as before
    again = [_finding("a", FaultType.MULTIPLICATIVE, 3000 / RATE)]
    relabel_frozen(again, values, ["a", "b", "c"], RATE, (0, 1000))
    assert again[0].onset_s == 15.0 and "since_s" not in again[0].evidence["frozen"]


def test_a_sensor_dead_while_the_structure_was_quiet_is_reported_from_its_death(tmp_path):
    """A 4-floor building whose first sensor dies at 70 s (an audit's case): reported
    from 80.42 s, with an ``other`` on a healthy sensor from 70.11 s that the detection
    filter alone put there. Now from 70.0 s, and the other one is taken for it."""
    t, Y, names = simulate_building(4, 120.0, 100.0, seed=19)
    Y[7000:, 0] = 0.0
    path = tmp_path / "dead.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: Y[:, j] for j, n in enumerate(names)}
    )
    analysis = analyze([path], RunOptions())
    (f,) = analysis.findings
    assert (f.channel, f.type, f.magnitude) == (names[0], FaultType.MULTIPLICATIVE, {"gain": 0.0})
    assert f.onset_s == pytest.approx(70.0, abs=0.011)
    assert any("it starts where they froze" in n for n in analysis.notes)


def test_a_frozen_finding_ends_where_its_readings_moved_again():
    """A sensor dead from row 3000 to 4400 whose end a detector saw 147 rows late: the
    readings over that period are not frozen, yet they are from the onset for 90 % of
    it and then move: the finding ends where they moved again, dead, with gain 0 (not
    the detector's 0.174). A fault that reads flat away from zero for less than 90 % of
    its period keeps its type and end."""
    rng = np.random.default_rng(2)
    values = rng.standard_normal((6000, 2))
    values[3000:4400, 0] = 0.0
    values[3000:3800, 1] = 1.5  # flat for 800 of 1547 rows: some other fault
    found = [
        Finding("a", FaultType.MULTIPLICATIVE, 15.0, 4547 / RATE, {"gain": 0.174}, 1.0, "df"),
        Finding("b", FaultType.OTHER, 15.0, 4547 / RATE, {"rms": 1.0}, 1.0, "df"),
    ]
    (note,) = relabel_frozen(found, values, ["a", "b"], RATE, (0, 1000))
    assert (found[0].onset_s, found[0].end_s, found[0].magnitude) == (15.0, 22.0, {"gain": 0.0})
    assert found[0].evidence["frozen"]["until_s"] == 22.0
    assert found[0].evidence["frozen"]["alarmed_to_s"] == 4547 / RATE
    assert "the detectors saw it to 22.735 s: it ends where they moved again" in note
    assert (found[1].type, found[1].end_s) == (FaultType.OTHER, 4547 / RATE)
    assert "frozen" not in found[1].evidence


def test_noise_a_flicker_or_an_early_onset_do_not_hide_a_frozen_sensor():
    """A review's cases: a sensor stuck with noise at 0.3 % of its healthy spread; a dead
    one whose reading flickers by 0.1 % once, half-way and near the end of its period; a
    dead one whose finding begins 2 samples before it died. Each is frozen over its
    fault, from where it froze to where it moved again."""
    rng = np.random.default_rng(0)
    values = rng.standard_normal((30000, 4))
    values[10000:, 0] = 1.75 + 0.003 * rng.standard_normal(20000)
    values[10000:20000, 1] = 0.0
    values[15000, 1] = 1e-3
    values[10000:20000, 2] = 0.0
    values[19600, 2] = 1e-3
    values[10000:, 3] = 0.0
    found = [
        Finding("a", FaultType.ADDITIVE, 10000 / RATE, None, {"offset": 1.7}, 1.0, "df"),
        Finding(
            "b", FaultType.MULTIPLICATIVE, 10000 / RATE, 20000 / RATE, {"gain": 0.2}, 1.0, "df"
        ),
        Finding(
            "c", FaultType.MULTIPLICATIVE, 10000 / RATE, 20000 / RATE, {"gain": 0.2}, 1.0, "df"
        ),
        Finding("d", FaultType.MULTIPLICATIVE, 9998 / RATE, None, {"gain": 0.2}, 1.0, "df"),
    ]
    relabel_frozen(found, values, ["a", "b", "c", "d"], RATE, (0, 5000))
    assert found[0].type is FaultType.OTHER
    assert found[0].magnitude["stuck_at"] == pytest.approx(1.75, abs=1e-3)
    for f in found[1:]:
        assert f.type is FaultType.MULTIPLICATIVE and f.magnitude == {"gain": 0.0}, f
    assert [(f.onset_s, f.end_s) for f in found[1:3]] == [(50.0, 100.0)] * 2
    assert found[3].onset_s == 9998 / RATE  # (as the detectors saw it: already frozen)


def test_a_gain_that_read_dead_from_its_onset_is_a_dead_sensor_to_its_revival():
    """A sensor dead from row 3000 to 4400 whose finding ran on to row 6000 (another
    fault in its residual, or the record's end): frozen at zero for 1400 of 3000 rows,
    less than 90 %, yet a gain of at least 0.1 varies with the structure and never reads
    flat at zero for a long alarm window: the gain the residual fitted (0.21) is the
    dead readings and the alive ones after taken for one fault. Dead, to where the
    readings moved again. A real gain of 0.2, a sensor dead for 7 s then offset by
    1 sd to the finding's end (the same finding: the offset is what lasts), and a gain
    flat at zero for less than a long alarm window (2 s at 200 Hz is 400 rows) keep
    their type and end."""
    rng = np.random.default_rng(3)
    values = rng.standard_normal((9000, 4))
    values[3000:4400, 0] = 0.0
    values[3000:, 1] *= 0.2  # a real gain
    values[3000:4400, 2] = 0.0  # dead, then a lasting offset
    values[4400:, 2] += 1.0
    values[3000:3300, 3] = 0.0  # flat at zero for 1.5 s only
    found = [
        Finding("a", FaultType.MULTIPLICATIVE, 15.0, 30.0, {"gain": 0.21}, 1.0, "df"),
        Finding("b", FaultType.MULTIPLICATIVE, 15.0, 30.0, {"gain": 0.2}, 1.0, "df"),
        Finding("c", FaultType.ADDITIVE, 15.0, 30.0, {"offset": 0.6}, 1.0, "df"),
        Finding("d", FaultType.MULTIPLICATIVE, 15.0, None, {"gain": 0.5}, 1.0, "df"),
    ]
    (note,) = relabel_frozen(found, values, ["a", "b", "c", "d"], RATE, (0, 2000))
    assert (found[0].onset_s, found[0].end_s, found[0].magnitude) == (15.0, 22.0, {"gain": 0.0})
    assert found[0].evidence["frozen"]["alarmed_to_s"] == 30.0
    assert note.startswith("a from 15.000 s to 22.000 s: dead (reads 0)")
    assert "the detectors saw it to 30.000 s: it ends where they moved again" in note
    assert [(f.type, f.end_s) for f in found[1:]] == [
        (FaultType.MULTIPLICATIVE, 30.0),
        (FaultType.ADDITIVE, 30.0),
        (FaultType.MULTIPLICATIVE, None),
    ]
    assert found[1].magnitude == {"gain": 0.2} and found[3].magnitude == {"gain": 0.5}
    assert not any("frozen" in f.evidence for f in found[1:])


def test_a_fault_of_any_type_that_read_dead_from_its_onset_is_a_dead_sensor():
    """A dead sensor whose finding ran on past its revival is not always fitted as a gain:
    over the dead readings and the alive ones after, the residual is often neither shape
    (``other``, offset about 0: 28 of 160 runs of ``sweep_dead_pairs.py``, regenerated
    past the revival at edb23a8). No fault of an alive sensor reads flat at zero for a
    long alarm window, whatever its type: each is dead, to where its readings moved
    again. Not a sensor stuck away from zero for part of its finding, one that merely
    reads small (a gain of 0.1, the structure at 2 % of its healthy amplitude), nor one
    that read zero for less than a long alarm window: those keep their type and end."""
    rng = np.random.default_rng(5)
    values = rng.standard_normal((9000, 7))
    values[3000:4400, :3] = 0.0  # dead, then alive again
    values[3000:4400, 3] = 1.5  # stuck away from zero, then alive again
    values[3000:, 4] *= 0.1  # reads small: the least gain
    values[3000:, 5] *= 0.02  # the structure nearly at rest
    values[3000:3300, 6] = 0.0  # flat at zero for 1.5 s only
    kinds = [FaultType.OTHER, FaultType.ADDITIVE, FaultType.DRIFT, FaultType.OTHER]
    kinds += [FaultType.OTHER, FaultType.ADDITIVE, FaultType.OTHER]
    found = [
        Finding(c, k, 15.0, 30.0, {"offset": 0.01}, 1.0, "df")
        for c, k in zip("abcdefg", kinds, strict=True)
    ]
    notes = relabel_frozen(found, values, list("abcdefg"), RATE, (0, 2000))
    for f in found[:3]:
        assert (f.type, f.magnitude, f.onset_s, f.end_s) == (
            FaultType.MULTIPLICATIVE,
            {"gain": 0.0},
            15.0,
            22.0,
        )
        assert f.evidence["frozen"]["alarmed_to_s"] == 30.0
    assert [n.split(": ")[0] for n in notes] == [f"{c} from 15.000 s to 22.000 s" for c in "abc"]
    assert "(the residual alone read it as other;" in notes[0]
    for f, k in zip(found[3:], kinds[3:], strict=True):
        assert (f.type, f.magnitude, f.end_s) == (k, {"offset": 0.01}, 30.0)
        assert "frozen" not in f.evidence


def test_a_dead_spell_then_a_lasting_fault_keeps_the_fault():
    """Dead from row 3000 to 4400, then a lasting fault to the finding's end: an offset of
    1 sd, a drift of 0.1 sd/s, stuck at 1.5 sd. The finding is that fault (the dead spell
    its first seconds): its readings after the revival are off the healthy mean, as a
    dead sensor's alive ones are not. Each keeps its type, magnitude and end (made dead
    to row 4400 at the commit before this guard, the lasting fault lost). A healthy
    sensor after its dead spell is dead to its revival, as before."""
    rng = np.random.default_rng(6)
    values = rng.standard_normal((9000, 4))
    values[3000:4400, :] = 0.0
    values[4400:, 0] += 1.0
    values[4400:, 1] += 0.1 * np.arange(4600) / RATE
    values[4400:, 2] = 1.5
    kinds = [FaultType.ADDITIVE, FaultType.DRIFT, FaultType.OTHER, FaultType.OTHER]
    found = [
        Finding(c, k, 15.0, None, {"offset": 0.5}, 1.0, "df")
        for c, k in zip("abcd", kinds, strict=True)
    ]
    (note,) = relabel_frozen(found, values, list("abcd"), RATE, (0, 2000))
    for f, k in zip(found[:3], kinds, strict=False):
        assert (f.type, f.magnitude, f.onset_s, f.end_s) == (k, {"offset": 0.5}, 15.0, None)
        assert "frozen" not in f.evidence
    assert (found[3].type, found[3].end_s) == (FaultType.MULTIPLICATIVE, 22.0)
    assert note.startswith("d from 15.000 s to 22.000 s: dead (reads 0)")


def test_missing_readings_do_not_count_towards_a_dead_stretch():
    """0.3 s of zeros (60 rows), 3 s of missing readings, then alive readings to the
    finding's end: the frozen stretch runs over the gap (missing readings do not end
    it), yet only 60 finite readings read zero, fewer than a long alarm window's 400:
    no evidence of a dead sensor, and the finding keeps its type (made dead to the gap's
    end at the commit before). 400 zeros then the gap are dead, to the gap's end."""
    rng = np.random.default_rng(8)
    values = rng.standard_normal((9000, 2))
    values[3000:3060, 0] = 0.0
    values[3060:3660, 0] = np.nan
    values[3000:3400, 1] = 0.0
    values[3400:4000, 1] = np.nan
    found = [Finding(c, FaultType.OTHER, 15.0, None, {"rms": 1.0}, 1.0, "df") for c in "ab"]
    relabel_frozen(found, values, ["a", "b"], RATE, (0, 2000))
    assert (found[0].type, found[0].end_s) == (FaultType.OTHER, None)
    assert "frozen" not in found[0].evidence
    assert (found[1].type, found[1].end_s) == (FaultType.MULTIPLICATIVE, 20.0)


def test_a_channel_that_reads_zero_when_healthy_is_not_dead_from_its_onset():
    """A quiet channel on a coarse converter: its healthy readings (sd 0.39 of a quantum)
    are exactly 0 85 % of the time, and read frozen at zero (no 5 readings in a row off
    it) for far longer than a long alarm window. A real drift from row 3000, and an
    oscillation about the healthy mean growing from row 3000 (``other``: its readings
    after the first seconds average the healthy mean, as a revived sensor's do), read
    zero for their first seconds as the healthy channel did: no evidence of a dead
    sensor, and each keeps its type and end. A channel whose healthy readings do not sit
    at zero and that reads zero 3000-3800, then its healthy readings to the finding's
    end, is dead to row 3800."""
    rng = np.random.default_rng(7)
    x = 0.35 * rng.standard_normal((9000, 3))
    k = np.arange(6000) / RATE
    x[3000:, 0] += 0.15 * k
    x[3000:, 1] += 0.15 * k * np.sin(2 * np.pi * 5.0 * k)
    values = np.round(x)
    values[:, 2] = rng.standard_normal(9000)
    values[3000:3800, 2] = 0.0
    assert np.mean(values[:2000, 0] == 0) > 0.8
    found = [
        Finding("a", FaultType.DRIFT, 15.0, None, {"rate_per_s": 0.15}, 1.0, "df"),
        Finding("b", FaultType.OTHER, 15.0, None, {"rms": 1.0}, 1.0, "df"),
        Finding("c", FaultType.OTHER, 15.0, 30.0, {"rms": 1.0}, 1.0, "df"),
    ]
    (note,) = relabel_frozen(found, values, list("abc"), RATE, (0, 2000))
    assert [(f.type, f.onset_s, f.end_s) for f in found[:2]] == [
        (FaultType.DRIFT, 15.0, None),
        (FaultType.OTHER, 15.0, None),
    ]
    assert not any("frozen" in f.evidence for f in found[:2])
    assert (found[2].type, found[2].end_s) == (FaultType.MULTIPLICATIVE, 19.0)
    assert note.startswith("c from 15.000 s to 19.000 s: dead (reads 0)")


def test_a_dead_sensor_in_an_anomaly_no_detector_attributed_is_found_by_its_readings():
    """Anomalies the detectors attributed to no sensor at 14.7 s (``df``, which estimates
    every channel), 15.0 s (``em``, which estimates none) and 38.0 s. Channel a reads 0
    from 15 to 27 s: a dead sensor, found (gain 0, from where it froze to where it moved
    again), its lead the detector nearest that estimates it. Not found: b, zero for 1 s
    only (less than a long alarm window); c, dead 30-35 s, long before the anomaly at
    38 s; d, dead 15-27 s but with a finding of its own then; e, a measured input; and a
    itself when the other channels read their noise alone then (the structure at rest),
    or when its healthy readings read zero for long in the training window (``--model``:
    as the model saved it; not known in a model saved before, and then not judged)."""
    rng = np.random.default_rng(9)
    values = rng.standard_normal((9000, 5))
    values[3000:5400, 0] = 0.0
    values[3000:3200, 1] = 0.0
    values[6000:7000, 2] = 0.0
    values[3000:5400, 3:] = 0.0
    names = list("abcde")

    def result(name: str, at: list[float], estimates: bool) -> DetectorResult:
        residuals = {c: np.zeros(9000) for c in names} if estimates else {}
        unattributed = [(t, ("b",), ()) for t in at]
        sigma = dict.fromkeys(residuals, 0.1)  # (the channels' noise)
        return DetectorResult(
            name, tuple(names), {}, [], residuals, sigma=sigma, unattributed=unattributed
        )

    results = [result("df", [14.7, 38.0], True), result("em", [15.0], False)]
    own = [Finding("d", FaultType.OTHER, 16.0, 26.0, {"rms": 1.0}, 1.0, "df")]
    healthy = {c: (0.0, 1.0) for c in names}
    found, notes = dead_unattributed(
        results, own, values, names, RATE, healthy, (0, 2000), 0, ("e",)
    )
    assert [(f.channel, f.type, f.onset_s, f.end_s, f.magnitude, f.detector) for f in found] == [
        ("a", FaultType.MULTIPLICATIVE, 15.0, 27.0, {"gain": 0.0}, "df")
    ]
    (f,) = found
    assert f.evidence["detectors"] == ["df", "em"] and f.evidence["unattributed_s"] == [14.7, 15.0]
    assert f.evidence["frozen"]["was"] == "unattributed"
    (note,) = notes
    assert note.startswith("a from 15.000 s to 27.000 s: dead (reads 0)")
    rest = values.copy()  # the structure at rest: every other channel reads its noise
    rest[3000:5400, 1:] *= 0.1
    assert (
        dead_unattributed(results, own, rest, names, RATE, healthy, (0, 2000), 0, ("e",))[0] == []
    )
    values[500:1000, 0] = 0.0  # zero for long in training: its zeros say nothing
    assert (
        dead_unattributed(results, own, values, names, RATE, healthy, (0, 2000), 0, ("e",))[0] == []
    )
    # --model: no training rows, the channels reading zero at rest as the model saved them
    for zeros, count in (((), 1), (("a",), 0), (None, 0)):  # (None: an older model's)
        found = dead_unattributed(
            results, own, values, names, RATE, healthy, None, 0, ("e",), zeros
        )
        assert len(found[0]) == count
    # no anomaly near it of a detector that estimates it (em's at 15.0 s, twice: one per
    # channel group): df, which estimates it, leads (--corrected takes its estimate), and
    # the onset is given once
    late = [result("df", [38.0], True), result("em", [15.0, 15.0], False)]
    (f,) = dead_unattributed(late, own, values, names, RATE, healthy, None, 0, ("e",), ())[0]
    assert (f.detector, f.evidence["detectors"], f.evidence["unattributed_s"]) == (
        "df",
        ["em"],
        [15.0],
    )


def test_a_dead_spell_then_a_gain_keeps_the_gain_from_the_revival(tmp_path):
    """The 5-floor building (seed 11, 100 Hz, 200 s, trained on 0-80 s): s2 dead from 120
    to 124 s, then at a gain of 0.5 to the end. Every detector saw one gain of 0.45-0.49
    from 120 s to the end; its readings read zero from the onset, so it was a dead sensor
    to 124.03 s only, the gain lost (``--corrected``: 0.62 sd of error after 124 s). Now
    the dead spell and, from the revival, the gain, which ``--corrected`` divides out.
    The same sensor dead 120-124 s only keeps its one finding (the control)."""
    t, y0, names = simulate_building(5, 200.0, 100.0, seed=11)
    for gain in (0.5, None):
        y = y0.copy()
        y[12000:12400, 2] = 0.0
        if gain is not None:
            y[12400:, 2] *= gain
        path = tmp_path / f"gain{gain}.csv"
        write_archive(
            path,
            "csv",
            np.round(t * 1e9).astype(np.int64),
            {n: y[:, j] for j, n in enumerate(names)},
        )
        analysis = analyze([path], RunOptions(train="0:80", corrected=True))
        got = [(f.type, f.onset_s, f.end_s, f.magnitude) for f in analysis.findings]
        dead = (FaultType.MULTIPLICATIVE, 120.0, pytest.approx(124.0, abs=0.05), {"gain": 0.0})
        if gain is None:
            assert got == [dead]
            continue
        assert got[0] == dead and len(got) == 2
        kind, onset, end, magnitude = got[1]
        assert (kind, end) == (FaultType.MULTIPLICATIVE, None)
        assert onset == pytest.approx(124.0, abs=0.05)
        assert magnitude["gain"] == pytest.approx(0.5, abs=0.02)
        fixed = np.asarray(analysis.corrected)[12500:, 2]
        err = np.sqrt(np.mean((fixed - y0[12500:, 2]) ** 2)) / y0[:8000, 2].std()
        assert err < 0.05


def test_only_a_revived_gain_of_its_own_goes_on_after_a_dead_spell():
    """Gains made dead from 15 to 20 s, the detectors' fault running on to 40 s: the
    lead detector's residual over a's revived readings is half its estimate (a gain of
    0.5 there), over b's healthy noise. a's gain goes on from the revival to 40 s, with
    the finding's events; b, healthy after its dead spell, gets none; nor does c, whose
    fault the detectors saw to 23 s, its residual a gain of 1.16 over the 3 s after
    the revival (the filters settling: judged only from a long alarm window after);
    nor does a while another sensor's finding is under way from before that."""
    rng = np.random.default_rng(10)
    n = 9000
    k = np.arange(n) / RATE
    reference = {c: np.sin(2 * np.pi * 1.3 * k + p) for c, p in (("a", 0.0), ("b", 1.0))}
    residuals = {c: 0.05 * rng.standard_normal(n) for c in "ab"}
    residuals["a"][4000:8000] -= 0.5 * reference["a"][4000:8000]
    reference["c"] = reference["a"]
    residuals["c"] = 0.05 * rng.standard_normal(n)
    residuals["c"][4000:4600] += 0.16 * reference["c"][4000:4600]
    lead = DetectorResult(
        "df", ("a", "b", "c"), {}, [], residuals, reference, sigma=dict.fromkeys("abc", 0.05)
    )
    found = []
    for c, to in (("a", 40.0), ("b", 40.0), ("c", 23.0)):
        f = Finding(c, FaultType.MULTIPLICATIVE, 15.0, 20.0, {"gain": 0.0}, 0.9, "df")
        f.evidence = {
            "detectors": ["df"],
            "frozen": {"was": "multiplicative", "until_s": 20.0, "alarmed_to_s": to},
        }
        found.append(f)
    more, notes = revived_gains(found, [lead], RATE, n)
    (g,) = more
    assert (g.channel, g.type, g.onset_s, g.end_s) == ("a", FaultType.MULTIPLICATIVE, 20.0, 40.0)
    assert g.magnitude["gain"] == pytest.approx(0.5, abs=0.01)
    assert g.evidence["revived_s"] == [15.0, 20.0] and "frozen" not in g.evidence
    assert notes[0].startswith("a from 20.000 s to 40.000 s: a gain of 0.5")
    # another sensor's fault under way from before the judged stretch: its estimate is off
    beside = Finding("x", FaultType.MULTIPLICATIVE, 18.0, 45.0, {"gain": 0.0}, 0.9, "df")
    assert revived_gains([found[0], beside], [lead], RATE, n) == ([], [])
    beside.onset_s = 30.0  # from later: judged before it, and the gain goes on to 40 s
    (g,) = revived_gains([found[0], beside], [lead], RATE, n)[0]
    assert (g.onset_s, g.end_s) == (20.0, 40.0)


def test_the_channels_that_read_zero_when_healthy_are_known_from_the_statistics_too():
    """The pipeline hands the channels' healthy statistics, not the training window, to
    the frozen check, which then knew no channel that reads zero when healthy (at
    8419bb2: the guard held only for callers that gave the window). Given the window
    beside the statistics, the coarse channel's oscillation growing about its healthy
    mean (``other``), which reads zero for its first seconds, keeps its type; given none
    (``--model``), it reads dead from its onset (its revived readings sit at the mean)."""
    rng = np.random.default_rng(7)
    x = 0.35 * rng.standard_normal((9000, 1))
    k = np.arange(6000) / RATE
    x[3000:, 0] += 0.15 * k * np.sin(2 * np.pi * 5.0 * k)
    values = np.round(x)
    stats = healthy_stats(values, ["a"], (0, 2000))
    for train, kind in (((0, 2000), FaultType.OTHER), (None, FaultType.MULTIPLICATIVE)):
        f = Finding("a", FaultType.OTHER, 15.0, None, {"rms": 1.0}, 1.0, "df")
        relabel_frozen([f], values, ["a"], RATE, stats, 0, train)
        assert f.type is kind

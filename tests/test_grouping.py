"""Channel groups (analyzer.grouping) and the pipeline's runs on them."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from analyzer import grouping, pipeline
from analyzer.detector_runs import skip_reasons
from analyzer.grouping import GROUP_SIZE, partition
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import simulate_building


def _building(floors: int, seconds: float = 120.0, rate: float = 50.0, seed: int = 3):
    t, Y, names = simulate_building(floors, seconds, rate, seed=seed, sensors_per_floor=2)
    return t, Y, names


def test_few_channels_are_one_group_in_their_order():
    _, Y, names = _building(4)
    groups, notes = partition(names, Y)
    assert groups == [tuple(names)]
    assert notes == []


def test_many_channels_are_cut_into_balanced_groups_of_correlated_sensors():
    floors = 20  # 40 channels: 3 groups of 13-14
    _, Y, names = _building(floors)
    groups, notes = partition(names, Y)
    k = math.ceil(len(names) / GROUP_SIZE)
    assert len(groups) == k
    assert sorted(c for g in groups for c in g) == sorted(names)  # each channel once
    assert all(len(g) <= GROUP_SIZE for g in groups)
    assert max(map(len, groups)) - min(map(len, groups)) <= 1
    for g in groups:  # each group keeps the channels' order
        assert list(g) == sorted(g, key=names.index)
    # the two sensors of a floor see the same motion: a cut of the ordering can part at
    # most one pair per boundary between groups
    where = {c: i for i, g in enumerate(groups) for c in g}
    parted = sum(where[f"s{2 * f}"] != where[f"s{2 * f + 1}"] for f in range(floors))
    assert parted <= k - 1
    # the floors form a chain, and each group is a stretch of it (neighbouring floors
    # predict each other best); the plain dendrogram order mixed far floors
    for g in groups:
        floors = {int(c[1:]) // 2 for c in g}
        assert max(floors) - min(floors) + 1 == len(floors), g
    assert len(notes) == 1 and f"in {k} groups of at most {GROUP_SIZE}" in notes[0]


def test_groups_follow_the_correlation_not_the_names():
    # two independent structures, their channels interleaved by name
    _, A, _ = _building(4, seed=1)
    _, B, _ = _building(4, seed=2)
    Y = np.empty((A.shape[0], 16))
    Y[:, 0::2], Y[:, 1::2] = A, B
    names = [f"c{i:02d}" for i in range(16)]
    groups, _ = partition(names, Y, size=8)
    assert sorted(groups) == [tuple(names[0::2]), tuple(names[1::2])]


def test_configured_groups_are_kept_and_the_rest_grouped():
    _, Y, names = _building(6)  # 12 channels
    cfg = [{"name": "low", "channels": names[:4]}, {"name": "mid", "channels": names[4:7]}]
    groups, notes = partition(names, Y, cfg, size=4)
    assert groups[:2] == [tuple(names[:4]), tuple(names[4:7])]
    assert sorted(c for g in groups[2:] for c in g) == sorted(names[7:])
    assert all(len(g) <= 4 for g in groups[2:])
    # without any configured group, no more than the size: one group of all
    groups, notes = partition(names, Y, [], size=12)
    assert groups == [tuple(names)] and notes == []


def test_a_single_leftover_channel_joins_the_group_it_correlates_with():
    _, Y, names = _building(3)  # s0..s5; s5 is s4's floor mate
    cfg = [{"name": "a", "channels": names[:2]}, {"name": "b", "channels": names[2:5]}]
    groups, notes = partition(names, Y, cfg)
    assert groups == [tuple(names[:2]), tuple(names[2:6])]
    assert any("s5 is in no [[group]]" in n for n in notes)


def test_a_configured_group_of_one_analyzed_channel_is_noted():
    _, Y, names = _building(3)
    groups, notes = partition(names, Y, [{"name": "lone", "channels": ["s0", "gone"]}])
    assert groups == [tuple(names)]  # s0 in no usable group: grouped with the rest
    assert any("lone" in n and "s0" in n for n in notes)
    with pytest.raises(ValueError, match="at least 2"):
        partition(names, Y, size=1)


def _faulty_csv(tmp_path, floors=6, seconds=240.0, rate=50.0, channel=3, onset_s=150.0):
    t, Y, names = _building(floors, seconds, rate, seed=7)
    k = int(onset_s * rate)
    Y[k:, channel] += 1.0 * Y[: k // 2, channel].std()
    path = tmp_path / "b.csv"
    header = "time," + ",".join(names)
    np.savetxt(path, np.column_stack([t, Y]), delimiter=",", header=header, comments="")
    return path, names


def test_grouped_run_finds_the_fault_and_joins_each_detector_over_its_groups(tmp_path, monkeypatch):
    path, names = _faulty_csv(tmp_path)
    whole = analyze([path], RunOptions(jobs=1))
    monkeypatch.setattr(pipeline, "partition", functools.partial(grouping.partition, size=6))
    grouped = analyze([path], RunOptions(jobs=2))
    assert any("12 channels analyzed in 2 groups" in n for n in grouped.notes)
    for a in (whole, grouped):
        assert [(f.channel, str(f.type)) for f in a.findings] == [("s3", "additive")]
        assert a.findings[0].onset_s == pytest.approx(150.0, abs=0.5)
    assert grouped.findings[0].magnitude["offset"] == pytest.approx(
        whole.findings[0].magnitude["offset"], rel=0.05
    )
    for r in grouped.results:  # one result per detector, over every channel
        assert list(r.channels) == names  # in the archive's order
        assert set(r.residuals) == set(names)
        if r.detector != "error_function":
            assert r.model["groups"] == 2
            assert [len(g["channels"]) for g in r.model["group_models"]] == [6, 6]
            assert set(r.model["training_tests"]) == set(names)
            assert set(r.model["windowed_tests"]) == set(names)
    # the run's false-alarm rate is shared among the groups by their channels
    bank = next(r for r in grouped.results if r.detector == "ar_kalman_bank")
    rates = {c: bank.thresholds[c]["false_alarm_rate"] for c in names}
    ref = next(r for r in whole.results if r.detector == "ar_kalman_bank")
    assert rates == pytest.approx({c: ref.thresholds[c]["false_alarm_rate"] for c in names})
    for r in grouped.results:  # the settings show the run's rate, not a group's share
        whole_r = next(w for w in whole.results if w.detector == r.detector)
        if "false_alarm_rate" in whole_r.params:
            assert r.params["false_alarm_rate"] == pytest.approx(whole_r.params["false_alarm_rate"])


def test_grouped_long_archive_path_gives_the_in_memory_findings(tmp_path, monkeypatch):
    path, _ = _faulty_csv(tmp_path)
    monkeypatch.setattr(pipeline, "partition", functools.partial(grouping.partition, size=6))
    memory = analyze([path], RunOptions(jobs=2))
    monkeypatch.setattr(pipeline, "MATERIALIZE_IN_MEMORY", 1000)  # the mapped path
    work = tmp_path / "work"
    work.mkdir()
    mapped = analyze([path], RunOptions(jobs=2), work)
    assert len(mapped.findings) == len(memory.findings) == 1
    a, b = mapped.findings[0], memory.findings[0]
    assert (a.channel, a.type, a.onset_s) == (b.channel, b.type, b.onset_s)
    assert a.magnitude["offset"] == pytest.approx(b.magnitude["offset"], rel=1e-6)


def test_skip_reasons_over_many_groups_make_one_readable_line():
    skipped = {
        "error_function": "needs [[group]] reference/uncertain sensors",
        "ar_kalman_bank (s0..s15)": "too little healthy data: 36 samples",
        "ar_kalman_bank (s16..s31)": "too little healthy data: 35 samples",
        "ar_kalman_bank (s32..s47)": "too little healthy data: 36 samples",
        "equivalent_model (s0..s15)": "equivalent_model needs 3 channels",
    }
    assert skip_reasons(skipped) == [
        "error_function: needs [[group]] reference/uncertain sensors",
        "ar_kalman_bank (s0..s15): too little healthy data: 36 samples "
        "(and on 2 more channel groups)",
        "equivalent_model (s0..s15) needs 3 channels",
    ]


def test_a_group_channel_not_analyzed_is_named():
    """A [[group]] naming a channel the archive does not have (a typo, say) was taken
    without a word."""
    rng = np.random.default_rng(0)
    train = rng.standard_normal((500, 3))
    groups, notes = partition(
        ["a", "b", "c"], train, [{"name": "g", "channels": ["a", "b", "/nosuch", "/nosuch"]}]
    )
    assert any({"a", "b"} <= set(g) for g in groups)
    assert notes[0] == (
        "[[group]] g: /nosuch not analyzed (not in the archive, left out by --channels, or "
        "constant: over the record or in the training window)"
    )

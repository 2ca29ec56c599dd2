"""Two faulty sensors at once, end to end: a simulated 3-floor building (6 sensors, 20
minutes at 100 Hz) with a lasting fault from 8 minutes on one sensor and a second one
from 14 minutes on a sensor of another floor, written as MCAP and analyzed with the
defaults (the cases of ``benchmarks/sweep_isolation.py --floors 3 --onset 0.4 --second
0.7``, seeds 0 and 3). Both are reported, each on its sensor with its type, and nothing
else. Before the second-fault rules of ``merge`` and the drift-through-its-onset fit of
``classify``, the second fault was taken for the first one spreading (seed 0), and the
first offset, its stretch taking in the second fault's trace, was read as a drift
(seed 3)."""

from __future__ import annotations

import numpy as np
import pytest

from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 100.0


@pytest.mark.parametrize(
    "seed, first, second",
    [
        (0, (1, "additive"), (3, "multiplicative")),
        (3, (1, "additive"), (2, "drift")),
    ],
)
def test_two_faults_at_once_are_both_reported(tmp_path, seed, first, second):
    duration = 1200.0
    t, Y, names = simulate_building(3, duration, RATE, seed=seed, sensors_per_floor=2)
    truth = []
    for (k, kind), onset in ((first, 480.0), (second, 840.0)):
        sd = float(np.std(Y[:, k]))
        size = {"additive": 0.5 * sd, "multiplicative": 1.3, "drift": sd / 600.0}[kind]
        Y[:, k] = inject_fault(Y[:, k], RATE, kind, onset, size, None)
        truth.append((f"/data.data[{k}]", kind, onset))
    path = tmp_path / "two.mcap"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    found = analyze([str(path)], RunOptions()).findings
    assert sorted((f.channel, f.type.value) for f in found) == sorted((c, k) for c, k, _ in truth)
    for f in found:
        onset = next(o for c, _, o in truth if c == f.channel)
        assert abs(f.onset_s - onset) < 10.0
        assert f.end_s is None


def test_coupled_follows_the_equivalent_models_sensor_network():
    """The bank and the detection filter estimate each sensor from all the others of a
    group; the equivalent model's residual of a sensor sees only its assistants' faults
    (direct propagation), or everything upstream (chained)."""
    from analyzer.detector_runs import coupled
    from analyzer.detectors.base import DetectorResult
    from analyzer.detectors.network import SensorNetwork

    def result(detector, channels, network=None):
        model = {} if network is None else {"network": network.as_dict()}
        return DetectorResult(detector, tuple(channels), {}, [], {}, model=model)

    ring = SensorNetwork(("a", "b", "c", "d"), {"b": ("a",), "c": ("b",), "d": ("c",), "a": ("d",)})
    chained = SensorNetwork(
        ("a", "b", "c", "d"), {"b": ("a",), "c": ("b",), "d": ("c",)}, propagation="chained"
    )
    test = coupled(
        [
            result("ar_kalman_bank", "abcd"),
            result("ar_kalman_bank", "xy"),
            result("equivalent_model", "abcd", ring),
            result("other_model", "abcd", chained),
        ]
    )
    assert test("ar_kalman_bank", "a", "c") and not test("ar_kalman_bank", "a", "x")
    assert test("equivalent_model", "b", "a")  # a assists b: its fault reaches b's residual
    assert not test("equivalent_model", "a", "b")  # b is a's target, not its assistant
    assert not test("equivalent_model", "c", "a")  # two steps up: not with direct propagation
    assert test("other_model", "c", "a") and not test("other_model", "a", "c")
    assert not test("equivalent_model", "a", "x")


def test_two_offsets_from_the_same_instant_are_both_reported(tmp_path):
    """Offsets on s3 and s8 of an 8-floor building (16 sensors) from the same instant
    (``sweep_isolation.py --onset 0.6 --second 0.6001``, seed 6): the bank's and the
    detection filter's estimators each see one of the two and isolate neither; the
    equivalent model names both, s8 unconfirmed, and s8 was taken for s3's fault
    spreading though s3 is no assistant of s8 in its network."""
    duration, onset = 1200.0, 720.0
    t, Y, names = simulate_building(8, duration, RATE, seed=6, sensors_per_floor=2)
    for k in (3, 8):
        Y[:, k] = inject_fault(Y[:, k], RATE, "additive", onset, 0.5 * float(np.std(Y[:, k])))
    path = tmp_path / "same.mcap"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    found = analyze([str(path)], RunOptions()).findings
    assert sorted((f.channel, f.type.value) for f in found) == [
        ("/data.data[3]", "additive"),
        ("/data.data[8]", "additive"),
    ]
    assert all(abs(f.onset_s - onset) < 1.0 for f in found)


def test_two_faults_from_one_instant_on_six_sensors_the_network_isolates_one(tmp_path):
    """An offset on s1 and a gain on s3 of a 3-floor building from the same instant
    (``sweep_isolation.py --floors 3 --onset 0.6 --second 0.6001``, seed 0): no estimator
    of the bank and no filter isolates either, and law 0 alone names no sensor of the
    five that alarm, which gave no finding and exit 0. The smallest explanations of
    the alarms, {s0, s3} and {s1, s3}, name s3; the run's notes say that one of s0, s1
    is faulty beside it, and the search again without s3 (analyzer.reconfigure) finds
    the offset on s1."""
    duration, onset = 1200.0, 720.0
    t, Y, names = simulate_building(3, duration, RATE, seed=0, sensors_per_floor=2)
    Y[:, 1] = inject_fault(Y[:, 1], RATE, "additive", onset, 0.5 * float(np.std(Y[:, 1])))
    Y[:, 3] = inject_fault(Y[:, 3], RATE, "multiplicative", onset, 1.3)
    path = tmp_path / "six.mcap"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    analysis = analyze([str(path)], RunOptions())
    assert [(f.channel, f.type.value) for f in analysis.findings] == [
        ("/data.data[1]", "additive"),
        ("/data.data[3]", "multiplicative"),
    ]
    s1, s3 = analysis.findings
    assert abs(s3.magnitude["gain"] - 1.3) < 0.01
    assert "searched_without" not in s3.evidence
    assert s1.evidence["searched_without"] == ["/data.data[3]"]
    offset = 0.5 * float(np.std(Y[: int(onset * RATE), 1]))
    assert abs(s1.magnitude["offset"] / offset - 1.0) < 0.1
    assert abs(s1.onset_s - onset) < 1.0
    (note,) = [n for n in analysis.notes if "beside the fault on /data.data[3]" in n]
    assert "one of /data.data[0], /data.data[1]" in note


@pytest.mark.parametrize(
    "seed, first, second, kind, size",
    [
        (1, 1, 4, "multiplicative", 1.5),
        (6, 0, 1, "additive", 2.0),
        (12, 0, 3, "drift", 0.02),
        (17, 5, 2, "multiplicative", 1.5),
    ],
)
def test_a_first_faults_end_hidden_by_a_later_one_is_found_without_its_sensor(
    tmp_path, seed, first, second, kind, size
):
    """A fault on one sensor from 100 to 200 s and an offset of 2 sd on another from 150
    to 250 s of the 6-floor building (``benchmarks/sweep_two_faults.py``). Seed 1, a gain
    of 1.5 on s1 and the offset on s4: the bank and the observers saw the gain to
    250.1 s, s4's end, and the detection filter lost it at 150.1 s, where both faults
    were on. Seed 6, an offset of 2 sd on s0 and the offset on s1: the bank saw s0's to
    225.8 s, the filter to 200.0 s. Seed 12, a drift of 0.02 sd/s on s0 and the offset
    on s3: the bank and the filter lost the drift at 150.08 s, where s3's offset began,
    the observers saw it to 200.01 s. Seed 17, a gain of 1.5 on s5 and the offset on s2:
    the filter and the observers lost the gain at 150.14 s, the bank saw it to 250.13 s,
    s2's end. Searched again without the later fault's sensor, the first ends at 200 s
    (before: 250.1 s, 225.8 s, 150.1 s, 150.1 s); the later keeps its stretch."""
    t, y0, names = simulate_building(6, 300.0, RATE, seed=seed)
    y = y0.copy()
    scaled = size if kind == "multiplicative" else size * float(y0[:, first].std())
    y[:, first] = inject_fault(y[:, first], RATE, kind, 100.0, scaled, 200.0)
    sd = float(y0[:, second].std())
    y[:, second] = inject_fault(y[:, second], RATE, "additive", 150.0, 2.0 * sd, 250.0)
    path = tmp_path / "two.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    (tmp_path / "work").mkdir()
    analysis = analyze([str(path)], RunOptions(), tmp_path / "work")
    found = {f.channel: f for f in analysis.findings}
    assert sorted(found) == sorted([names[first], names[second]])
    one, later = found[names[first]], found[names[second]]
    assert one.type.value == kind and abs(one.onset_s - 100.0) < 2.0
    assert one.end_s is not None and abs(one.end_s - 200.0) < 2.0
    assert abs(later.onset_s - 150.0) < 2.0 and abs(later.end_s - 250.0) < 2.0
    assert any(n.startswith(f"{kind} fault on {names[first]}: ended at") for n in analysis.notes)


def test_an_end_found_without_the_later_faults_sensor_says_so_in_its_evidence(tmp_path):
    """A gain of 1.5 on s1 from 100 to 200 s and an offset of 2 sd on s4 from 150 to
    250 s (seed 1): the gain's end, 200.4 s, is the bank's without s4, not an end any of
    the finding's own events saw (250.1 s, 150.1 s); its evidence says where it came
    from (before, only a note did) and the end it replaced, one of those events' (the
    bank's 250.1 s, or since the observers' event is a gain too, the forty-fourth
    session, the 150.1 s of theirs, which leads)."""
    t, y0, names = simulate_building(6, 300.0, RATE, seed=1)
    y = y0.copy()
    y[:, 1] = inject_fault(y[:, 1], RATE, "multiplicative", 100.0, 1.5, 200.0)
    y[:, 4] = inject_fault(y[:, 4], RATE, "additive", 150.0, 2.0 * float(y0[:, 4].std()), 250.0)
    path = tmp_path / "two.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), {n: y[:, i] for i, n in enumerate(names)}
    )
    (tmp_path / "work").mkdir()
    s1 = next(f for f in analyze([str(path)], RunOptions(), tmp_path / "work").findings)
    assert s1.channel == "s1" and abs(s1.end_s - 200.0) < 2.0
    assert all(abs(e.end_s - s1.end_s) > 2.0 for e in s1.events)
    said = s1.evidence["end_without"]
    assert said["left_out"] == "s4" and said["detector"] in s1.evidence["detectors"]
    assert said["was_s"] in {e.end_s for e in s1.events}


@pytest.mark.parametrize(
    "seed",
    [
        1,
        pytest.param(
            3,
            marks=pytest.mark.xfail(
                strict=True,
                raises=AssertionError,
                reason="open: with seed 3 the observers end s1's first part at 159.8 s "
                "(right) but take its part from 170.5 s for s4's or s5's fault, so s1's "
                "finding is not carried to the record's end",
            ),
        ),
    ],
)
def test_a_fault_that_began_again_beside_a_later_one_is_not_cut_at_its_first_part(tmp_path, seed):
    """A gain of 1.5 on s1 from 100 to 160 s and again from 170 s to the record's end,
    beside an offset of 2 sd on s4 from 150 s to the end. Searched without s4, the
    finding on s1 ended at 160.2 s, but its own events saw s1 faulty again from 170 s to
    the end (one finding: the observers saw the gain throughout): the fault goes on to
    the end (before: cut at 160.2 s, s1 reported healthy from there)."""
    t, y0, names = simulate_building(6, 300.0, RATE, seed=seed)
    y = y0.copy()
    for onset, end in ((100.0, 160.0), (170.0, None)):
        y[:, 1] = inject_fault(y[:, 1], RATE, "multiplicative", onset, 1.5, end)
    y[:, 4] = inject_fault(y[:, 4], RATE, "additive", 150.0, 2.0 * float(y0[:, 4].std()), None)
    path = tmp_path / "two.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    (tmp_path / "work").mkdir()
    found = analyze([str(path)], RunOptions(), tmp_path / "work").findings
    s1 = [(f.type.value, round(f.onset_s), f.end_s) for f in found if f.channel == "s1"]
    assert s1 == [("multiplicative", 100, None)]


@pytest.mark.parametrize(
    "seed, first, second, period",
    [(17, 5, 2, (150.0, 200.0)), (15, 3, 4, (150.0, 250.0))],
)
def test_a_later_faults_onset_inside_an_earlier_one_is_found_without_its_sensor(
    tmp_path, seed, first, second, period
):
    """An offset of 2 sd on one sensor from 100 s and one of 2 sd on another over
    ``period`` (``benchmarks/sweep_two_faults.py``). Seed 17 (``nested``), s5 to 250 s
    and s2 from 150 to 200 s: the bank saw s2's from 142.89 s to 215.04 s, the observers
    from 150.0 to 200.0 s. Seed 15 (``neighbour``), s3 to 200 s and s4 from 150 to
    250 s: the bank saw s4's from 111.56 s to 257.57 s (offset -0.08), the filter from
    150.0 to 250.0 s. The bank's onset led (before: each reported from the bank's);
    searched again without the earlier fault's sensor, the later one has its period, as
    every detector saw it there, and its size."""
    t, y0, names = simulate_building(6, 300.0, RATE, seed=seed)
    y = y0.copy()
    end = 250.0 if period[1] < 250.0 else 200.0
    y[:, first] = inject_fault(y[:, first], RATE, "additive", 100.0, 2.0 * y0[:, first].std(), end)
    offset = 2.0 * float(y0[:, second].std())
    y[:, second] = inject_fault(y[:, second], RATE, "additive", period[0], offset, period[1])
    path = tmp_path / "two.csv"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(path, "csv", t_ns, {n: y[:, i] for i, n in enumerate(names)})
    (tmp_path / "work").mkdir()
    found = {f.channel: f for f in analyze([str(path)], RunOptions(), tmp_path / "work").findings}
    assert sorted(found) == sorted([names[first], names[second]])
    one, later = found[names[first]], found[names[second]]
    assert abs(one.onset_s - 100.0) < 2.0 and abs(one.end_s - end) < 2.0
    assert abs(later.onset_s - period[0]) < 2.0 and abs(later.end_s - period[1]) < 2.0
    assert abs(later.magnitude["offset"] / offset - 1.0) < 0.1
    assert later.evidence["onset_without"]["left_out"] == names[first]


def test_chang_fig15_offset_then_drift_keeps_the_offsets_type_and_size(tmp_path):
    """Chang et al.'s Fig. 15 (3x2 building, 200 Hz, 50 s, --train 0:15): an offset of
    2 sd on s4 from 16 s, then a drift of 0.5 sd/s on s5 from 32 s. At seed 4 the
    detection filter and the observers, whose estimates of s4 take s5's drift in, read
    s4's stretch as a gain of 0.41 and outvoted the bank's offset (itself 5.06 for 5.36):
    the first fault's type changed with a later fault on another sensor. Its shape is now
    the one the detectors fitted again without s5 read (the search that looks for its
    end): an offset of the injected size."""
    rate = 200.0
    t, Y, names = simulate_building(n_floors=3, sensors_per_floor=2, duration_s=50.0, seed=4)
    offset = 2.0 * float(np.std(Y[:, 4]))
    Y[:, 4] = inject_fault(Y[:, 4], rate, "additive", 16.0, offset)
    Y[:, 5] = inject_fault(Y[:, 5], rate, "drift", 32.0, 0.5 * float(np.std(Y[:, 5])))
    path = tmp_path / "fig15.mcap"
    t_ns = np.round(t * 1e9).astype(np.int64)
    write_archive(
        path, "mcap", t_ns, {n: Y[:, i] for i, n in enumerate(names)}, layout="multiarray"
    )
    found = analyze([str(path)], RunOptions(train="0:15")).findings
    got = {f.channel: f for f in found}
    assert sorted(got) == ["/data.data[4]", "/data.data[5]"]
    first, second = got["/data.data[4]"], got["/data.data[5]"]
    assert first.type.value == "additive" and abs(first.onset_s - 16.0) < 0.1
    assert first.magnitude["offset"] == pytest.approx(offset, rel=0.02)
    assert second.type.value == "drift" and abs(second.onset_s - 32.0) < 0.5

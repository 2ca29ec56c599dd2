"""The sensor network of Wang & Song (2014, Section 6): roles, structures and Laws 0-4."""

import json

import numpy as np
import pytest

from analyzer.detectors.network import (
    Propagation,
    Role,
    SensorNetwork,
    StructureKind,
    network_from_config,
)

# Section 6.4, Eq. 34 and Fig. 11: O4 takes its assistant state from sensor 1, O2 from
# sensor 4, O3 from sensor 2 -- one line s1 -> s4 -> s2 -> s3.
FIG11 = {"s4": ["s1"], "s2": ["s4"], "s3": ["s2"]}


@pytest.fixture
def fig11() -> SensorNetwork:
    return network_from_config(["s1", "s2", "s3", "s4"], FIG11)


def test_fig11_roles_and_structure(fig11):
    assert fig11.roles() == {"s1": Role.HEAD, "s4": Role.LINK, "s2": Role.LINK, "s3": Role.FOOT}
    (line,) = fig11.structures()
    assert line.kind is StructureKind.LINES
    assert line.sensors == ("s1", "s4", "s2", "s3")  # positive order
    assert fig11.upstream("s2") == {"s1", "s4"}
    assert fig11.downstream("s4") == {"s2", "s3"}


def test_fig12_fault_on_sensor_two_is_isolated(fig11):
    # Fig. 12: residual 4 stays 0, residuals 2 and 3 are non-zero -> sensor two (Law 2)
    d = fig11.diagnose({"s2", "s3"})
    assert d.faulty == ("s2",)
    assert d.propagated == {"s3": ("s2",)}
    assert "law 2" in d.laws["s2"]
    # the head cannot be diagnosed by the observers (Law 2)
    assert set(fig11.undiagnosable()) == {"s1"}
    assert "head" in fig11.undiagnosable()["s1"]


@pytest.mark.parametrize("faulty", ["s4", "s2", "s3"])
def test_every_observed_sensor_of_the_line_is_isolated(fig11, faulty):
    alarming = {faulty} | set(fig11.targets(faulty))
    assert fig11.diagnose(alarming).faulty == (faulty,)


def test_typical_forms_of_fig9():
    # a dot, a line a -> b -> c with a branch b -> d -> e, and a circle f -> g -> h -> f
    # with a branch h -> i
    net = network_from_config(
        list("abcdefghiz"),
        {
            "b": ["a"],
            "c": ["b"],
            "d": ["b"],
            "e": ["d"],
            "g": ["f"],
            "h": ["g"],
            "f": ["h"],
            "i": ["h"],
        },
    )
    kinds = {(st.kind, st.sensors, st.attach) for st in net.structures()}
    assert (StructureKind.DOTS, ("z",), None) in kinds
    assert (StructureKind.LINES, ("a", "b", "c"), None) in kinds
    assert (StructureKind.BRANCHES, ("d", "e"), "b") in kinds
    assert (StructureKind.BRANCHES, ("i",), "h") in kinds
    circle = next(st for st in net.structures() if st.kind is StructureKind.CIRCLES)
    assert set(circle.sensors) == {"f", "g", "h"}
    assert net.role("z") is Role.DOT and net.role("a") is Role.HEAD
    und = net.undiagnosable()
    assert set(und) == {"z", "a"}
    assert und["z"].startswith("law 1")
    # Law 4: the branch is a line once b is diagnosed
    d = net.diagnose({"d", "e"})
    assert d.faulty == ("d",) and "law 4" in d.laws["d"]


def test_circle_direct_propagation_isolates_without_quasi_head():
    net = SensorNetwork.ring(["a", "b", "c", "d"], k=1)
    assert [st.kind for st in net.structures()] == [StructureKind.CIRCLES]
    assert net.undiagnosable() == {}
    for s in net.sensors:
        d = net.diagnose({s, *net.targets(s)})
        assert d.faulty == (s,)
        assert "law 3" in d.laws[s]


def test_circle_chained_propagation_needs_a_quasi_head():
    ass = {"b": ["a"], "c": ["b"], "a": ["c"]}
    chained = network_from_config(["a", "b", "c"], ass, propagation="chained")
    # Law 3: a fault anywhere makes every residual of the circle non-zero
    assert set(chained.undiagnosable()) == {"a", "b", "c"}
    d = chained.diagnose({"a", "b", "c"})
    assert d.faulty == () and set(d.ambiguous) == {"a", "b", "c"}
    # choosing a as quasi-head turns the circle into the line a -> b -> c
    q = network_from_config(["a", "b", "c"], ass, quasi_heads=["a"], propagation="chained")
    assert q.undiagnosable() == {}
    assert q.diagnose({"b", "c"}).faulty == ("b",)
    assert q.diagnose({"c"}).faulty == ("c",)
    fa = q.diagnose({"a", "b", "c"})
    assert fa.faulty == ("a",) and "quasi-head" in fa.laws["a"]


def test_chained_line_law2_uses_all_upstream_residuals():
    net = network_from_config(
        ["a", "b", "c", "d"], {"b": ["a"], "c": ["b"], "d": ["c"]}, propagation=Propagation.CHAINED
    )
    # a fault on b reaches c and d; only b has all upstream residuals quiet
    d = net.diagnose({"b", "c", "d"})
    assert d.faulty == ("b",)
    assert d.propagated == {"c": ("b",), "d": ("b", "c")}


def test_mutual_assistants_are_reported_and_ambiguous():
    net = network_from_config(["a", "b", "c"], {"a": ["b"], "b": ["a"], "c": ["a"]})
    und = net.undiagnosable()
    assert set(und) == {"a", "b"}
    assert "assists and is assisted by" in und["a"]
    d = net.diagnose({"a", "b"})
    assert d.faulty == () and d.ambiguous == ("a", "b")


def test_the_smallest_explanation_isolates_where_law_0_alone_does_not():
    """Where every alarming residual depends on an alarming sensor, the smallest sets of
    alarming sensors whose faults explain every alarm decide: a sensor in all of them is
    faulty. Mutual assistants a and b: a fault on b reaches a and b, not c, so c's alarm
    names a; without it each of a and b explains both alarms and both stay ambiguous."""
    net = network_from_config(["a", "b", "c"], {"a": ["b"], "b": ["a"], "c": ["a"]})
    d = net.diagnose({"a", "b", "c"})
    assert d.faulty == ("a",) and d.propagated == {"b": ("a",), "c": ("a",)}
    assert "explains every alarm" in d.laws["a"]
    assert net.diagnose({"a", "b"}).faulty == ()


def test_two_faults_at_once_in_the_network_of_a_three_floor_building():
    """The network the equivalent model built for a 3-floor building (6 sensors, two
    assistants each) and the alarms of an offset on s1 and a gain on s3 from the same
    instant (sweep_isolation.py --floors 3 --onset 0.6 --second 0.6001, seed 0): no one
    sensor explains s0 s1 s3 s4 s5; the pairs {s0, s3} and {s1, s3} do, so s3 is faulty
    and s0, s1 stay ambiguous (a fault on s1 shows in s0's residual). Two faults whose
    pair is the only explanation are both isolated."""
    ass = {
        "s0": ["s1", "s2"],
        "s1": ["s2", "s3"],
        "s2": ["s4", "s5"],
        "s3": ["s2", "s0"],
        "s4": ["s3", "s0"],
        "s5": ["s4", "s3"],
    }
    net = network_from_config([f"s{i}" for i in range(6)], ass)
    d = net.diagnose({"s0", "s1", "s3", "s4", "s5"})
    assert d.faulty == ("s3",) and set(d.ambiguous) == {"s0", "s1"}
    assert d.propagated == {"s4": ("s3",), "s5": ("s3",)}
    assert "two faults" in d.laws["s3"]
    ring = SensorNetwork.ring(["a", "b", "c", "d", "e", "f"], k=1)  # x assists the next
    both = ring.diagnose({"a", "b", "d", "e"})  # faults on a and d, each seen by its target
    assert both.faulty == ("a", "d")  # law 0 alone: b and e depend on an alarm, a and d not
    pair = network_from_config(["a", "b", "c"], {"a": ["b"], "b": ["a"], "c": ["a", "b"]})
    assert pair.diagnose({"a", "b", "c"}).faulty == ()  # {a} and {b} each explain all


def test_alarm_on_a_sensor_without_residual_is_ignored(fig11):
    d = fig11.diagnose({"s1"})
    assert d.faulty == () and d.ignored == ("s1",)


@pytest.mark.parametrize("m", [3, 4, 5, 7, 10])
@pytest.mark.parametrize("k", [1, 2, 3])
def test_design_makes_every_sensor_diagnosable(m, k):
    rng = np.random.default_rng(100 * m + k)
    for _ in range(10):
        A = rng.random((m, m))
        net = SensorNetwork.design([f"x{i}" for i in range(m)], A + A.T, k)
        assert net.undiagnosable() == {}
        for s in net.sensors:
            assert net.assistant_sensors(s)
            assert not set(net.assistant_sensors(s)) & set(net.targets(s))  # no mutual pair
            assert net.diagnose({s, *net.targets(s)}).faulty == (s,)


@pytest.mark.parametrize("seed", range(5))
def test_design_maximizes_the_worst_best_assistant(seed):
    """Step 1 of the design is max-min optimal: compare with every orientation of the
    pairs of five sensors."""
    import itertools

    rng = np.random.default_rng(seed)
    n = 5
    A = rng.random((n, n))
    S = A + A.T
    pairs = [(i, j) for i in range(n) for j in range(i + 1, n)]
    best = 0.0
    for bits in itertools.product((0, 1), repeat=len(pairs)):
        into = [[] for _ in range(n)]
        for (i, j), b in zip(pairs, bits, strict=True):
            into[j if b else i].append(S[i, j])
        if all(into):
            best = max(best, min(max(v) for v in into))
    names = [f"x{i}" for i in range(n)]
    net = SensorNetwork.design(names, S, k=2)
    got = min(
        max(S[t, names.index(a)] for a in net.assistant_sensors(s)) for t, s in enumerate(names)
    )
    assert got == pytest.approx(best)


def test_design_on_a_chain_of_floors():
    # similarity decaying with distance: adjacent floors alike. A tree of the strongest
    # pairs leaves one floor out, so the worst sensor gets a next-but-one neighbour.
    n = 5
    S = np.array([[0.9 ** abs(i - j) for j in range(n)] for i in range(n)])
    net = SensorNetwork.design([f"f{i}" for i in range(n)], S, k=2)
    for t in range(n):
        best = max(S[t, int(a[1:])] for a in net.assistant_sensors(f"f{t}"))
        assert best >= 0.81 - 1e-12


def test_as_dict_is_json_friendly(fig11):
    doc = json.loads(json.dumps(fig11.as_dict()))
    assert doc["roles"]["s1"] == "head"
    assert {"from": "s1", "to": "s4"} in doc["edges"]
    assert doc["structures"] == [{"kind": "lines", "sensors": ["s1", "s4", "s2", "s3"]}]
    assert "s1" in doc["undiagnosable"]


def test_bad_networks_are_refused():
    with pytest.raises(ValueError, match="unknown sensor 'q'"):
        network_from_config(["a", "b"], {"a": ["q"]})
    with pytest.raises(ValueError, match="own assistant"):
        network_from_config(["a", "b"], {"a": ["a"]})
    with pytest.raises(ValueError, match="unknown target"):
        network_from_config(["a", "b"], {"q": ["a"]})
    with pytest.raises(ValueError, match="at least 3 sensors"):
        SensorNetwork.ring(["a", "b"])
    with pytest.raises(ValueError, match="unknown sensor"):
        network_from_config(["a", "b"], {"a": ["b"]}).diagnose({"x"})

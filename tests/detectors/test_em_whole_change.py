"""The equivalent model under a change of the excitation (EOV probe, P1): a burst of
excitation x3 on a healthy 4-channel building made law 0 name s1, whose only assistant's
residual is mostly sensor noise, and s2's coincident alarm "confirmed" it. An alarm the
residuals blind to a sensor share is attributed to no sensor now, and a target confirms
only when the sensor's fault estimate explains its alarm (:func:`chain`); a real fault
on one sensor is still isolated."""

import numpy as np
import pytest

from analyzer.detectors.base import Dataset, Event, FaultType, RunContext
from analyzer.detectors.equivalent_model import EquivalentModel, Grade, _judge, chain
from analyzer.detectors.network import network_from_config
from analyzer.simulate import (
    band_limited_noise,
    inject_fault,
    shear_building,
    simulate_building,
    simulate_response,
)

RATE = 100.0
DURATION = 600.0
TRAIN = (0, int(0.2 * DURATION * RATE))
BURST = (360.0, 405.0)


def _building(seed: int, factor: float) -> np.ndarray:
    """2 floors x 2 accelerometers, 10 min, the excitation x``factor`` over ``BURST``;
    sensor noise 20 dB below each channel's training RMS, fixed in absolute terms
    (``benchmarks/sweep_eov.py``'s burst3 case)."""
    rng = np.random.default_rng(seed)
    model = shear_building(2, 1.01, 0.02)
    n = int(DURATION * RATE)
    t = np.arange(n) / RATE
    ground = band_limited_noise(n, RATE, min(0.4 * RATE, 2.0 * model.frequencies_hz[-1]), rng)
    ground *= np.where((t >= BURST[0]) & (t < BURST[1]), factor, 1.0)
    clean = np.repeat(simulate_response(model, ground, RATE), 2, axis=1)
    rms = np.sqrt(np.mean(clean[: TRAIN[1]] ** 2, axis=0))
    return clean + rng.standard_normal(clean.shape) * rms / 10.0


@pytest.fixture(scope="module")
def burst():
    Y = _building(0, 3.0)
    ds = Dataset(Y, ("s0", "s1", "s2", "s3"), RATE, TRAIN)
    det, ctx = EquivalentModel(), RunContext()
    return Y, det, det.fit(ds, ctx), ctx


def _run(det, model, ctx, Y):
    return det.run(model, Dataset(Y, ("s0", "s1", "s2", "s3"), RATE, TRAIN), ctx)


def test_a_burst_of_excitation_is_attributed_to_no_sensor(burst):
    """Every channel's response rose ~3x over the burst: before, three `other` events on s1
    (law 0, confirmed by s2); now none, and the alarms are unattributed, as the bank's."""
    Y, det, model, ctx = burst
    res = _run(det, model, ctx, Y)
    assert res.events == [], [(e.channel, e.onset_s, e.evidence) for e in res.events]
    assert res.unattributed
    assert all(BURST[0] <= t0 <= BURST[1] and not beside for t0, _, beside in res.unattributed)
    assert any("the data changed as a whole" in n for n in res.notes)
    changed = [d for d in res.model["decisions"] if "changed" in d]
    assert changed and all("grade" in d for d in changed)


@pytest.mark.parametrize("channel", [0, 1, 2, 3])
def test_an_offset_after_the_burst_is_still_isolated(burst, channel):
    """The same record with a lasting 2 sd offset on one sensor from 480 s, after the
    burst: that sensor alone, an offset, confirmed by a target whose alarm its fault
    estimate explains."""
    Y, det, model, ctx = burst
    Yf = Y.copy()
    Yf[int(480 * RATE) :, channel] += 2.0 * np.std(Y[: TRAIN[1], channel])
    res = _run(det, model, ctx, Yf)
    after = [e for e in res.events if e.onset_s > BURST[1]]
    assert [(e.channel, e.type) for e in after] == [(f"s{channel}", FaultType.ADDITIVE)]
    assert after[0].evidence["confirmed_by"]
    assert after[0].evidence["grade"]["blind_median"] < 1.0


def test_a_noise_burst_on_one_sensor_is_still_isolated():
    """A sensor's own noise burst (1 sd of white noise for 30 s, an `other` fault) under
    steady excitation: its residual alarms, its targets' alarms are its doing (their
    chained residuals stay quiet), so it is reported."""
    Y = _building(1, 1.0)
    ds = Dataset(Y, ("s0", "s1", "s2", "s3"), RATE, TRAIN)
    det, ctx = EquivalentModel(), RunContext()
    model = det.fit(ds, ctx)
    Yf = Y.copy()
    a, b = int(400 * RATE), int(430 * RATE)
    Yf[a:b, 2] += np.std(Y[: TRAIN[1], 2]) * np.random.default_rng(7).standard_normal(b - a)
    res = _run(det, model, ctx, Yf)
    assert [e.channel for e in res.events] == ["s2"]
    assert res.events[0].evidence["confirmed_by"]


def test_chain_takes_any_fault_of_the_assistant_out():
    """``zeta_t + h_ts * zeta_s`` holds none of a fault on ``s``, whatever its shape: the
    observers are linear, so the chained residual with and without the fault agree."""
    Y = _building(2, 1.0)
    names = ("s0", "s1", "s2", "s3")
    det, ctx = EquivalentModel(), RunContext()
    model = det.fit(Dataset(Y, names, RATE, TRAIN), ctx)
    net = model.network
    t = next(n for n in names if net.assistant_sensors(n))
    s = net.assistant_sensors(t)[0]
    ob_t = next(o for o in model.observers if names[o.target] == t)
    ob_s = next(o for o in model.observers if names[o.target] == s)
    h = ob_t.relation.coef[ob_t.relation.assistants.index(names.index(s))]
    Yf = Y.copy()
    k = names.index(s)
    Yf[30000:, k] += 3.0 * np.std(Y[:, k])  # an offset
    Yf[40000:, k] *= 1.5  # and a gain on top
    out = []
    for data in (Y, Yf):
        zt, _ = det._fault_estimate(ob_t.observer, ob_t.relation, data, ob_t.target)
        zs, _ = det._fault_estimate(ob_s.observer, ob_s.relation, data, ob_s.target)
        out.append(chain(zt, zs, h))
    scale = float(np.std(out[0]))
    np.testing.assert_allclose(out[1], out[0], atol=1e-9 * max(scale, 1.0) * 1e3)
    assert (t, s) in model.chained


def _net():
    return network_from_config(
        ["s0", "s1", "s2", "s3"],
        {"s0": ["s1", "s2"], "s1": ["s3"], "s2": ["s1"], "s3": ["s2", "s0"]},
    )


def test_judge_refuses_what_the_blind_residuals_share():
    """s1's alarm at 1.6 of its threshold while the residuals that cannot see it (s3's,
    and s0's and s2's with s1's fault estimate taken out) are at 1.5: the data changed."""
    g = Grade({"s0": 0.9, "s1": 1.6, "s2": 1.6, "s3": 0.5}, {"s0": 1.55, "s2": 1.65})
    j = _judge(_net(), "s1", ["s2"], g)
    assert j.changed and "changed as a whole" in j.changed and j.confirmed == []
    assert j.evidence["blind_median"] == pytest.approx(1.55)


def test_judge_a_target_confirms_only_what_the_fault_estimate_explains():
    """s2's alarm (2.0) is s1's doing when its chained residual is quiet (0.3); when the
    chained one still alarms (1.8) s2 saw something else: no sensor is blamed. A target
    whose alarm did not begin with s1's (not in ``alarmed``) is weighed all the same."""
    net = _net()
    quiet = {"s0": 0.4, "s1": 3.0, "s2": 2.0, "s3": 0.4}
    j = _judge(net, "s1", ["s2"], Grade(quiet, {"s0": 0.5, "s2": 0.3}))
    assert j.changed is None and j.confirmed == ["s2"]
    assert _judge(net, "s1", [], Grade(quiet, {"s0": 0.5, "s2": 0.3})).confirmed == ["s2"]
    j = _judge(net, "s1", ["s2"], Grade(quiet, {"s0": 0.5, "s2": 1.8}))
    assert j.changed and "explains none of its target sensors' residuals" in j.changed
    # a quiet target whose chained residual alarms contradicts s1's fault as well
    j = _judge(net, "s1", [], Grade({**quiet, "s2": 0.6}, {"s0": 0.5, "s2": 1.4}))
    assert j.changed and "s2's at 1.40" in j.changed
    # under its threshold but not mostly explained (0.95 > 0.5 x 1.05): neither
    marginal = {**quiet, "s2": 1.05}
    j = _judge(net, "s1", ["s2"], Grade(marginal, {"s0": 0.5, "s2": 0.95}))
    assert j.changed is None and j.confirmed == []
    # a residual that sees a fault still under way says nothing of this one
    busy = {"s0": 0.4, "s1": 3.0, "s2": 0.4, "s3": 2.5}
    j = _judge(net, "s1", [], Grade(busy, {"s0": 2.4, "s2": 2.6}), lasting={"s3"})
    assert j.changed is None


def test_isolate_reports_a_changed_alarm_as_unattributed():
    """:meth:`EquivalentModel._isolate` with a grade: the alarm of s1 confirmed by s2's
    coincident alarm (law 0) is withheld and its decision says why."""

    def ev(channel, t0):
        return Event(channel, t0, t0 + 10.0, FaultType.OTHER, {}, 0.8, "equivalent_model",
                     {"first_alarm_s": t0})  # fmt: skip

    cands = {"s1": [ev("s1", 361.76)], "s2": [ev("s2", 362.31)]}
    g = Grade({"s0": 0.9, "s1": 1.6, "s2": 1.6, "s3": 0.5}, {"s0": 1.55, "s2": 1.65})
    events, notes, decisions = EquivalentModel._isolate(
        _net(), cands, 2.0, None, lambda s, t, also=(): g
    )
    assert events == []
    assert decisions[0]["changed"] == ["s1", "s2"]
    assert any("s1 at 361.760 s not attributed" in n for n in notes)
    # without a grade, the alarms alone (as before): s1, confirmed by s2
    events, _, _ = EquivalentModel._isolate(_net(), cands, 2.0)
    assert [(e.channel, e.evidence["confirmed_by"]) for e in events] == [("s1", ["s2"])]


def test_judge_two_faults_at_once_are_not_a_change_of_the_whole():
    """Offsets on s1 and s3 from the same instant (s1 assists s2, s2 assists s0 and s3,
    s3 assists s4): the residuals that cannot see s1 alarm with s3's fault (s3's and
    s4's; median 1.75 against s1's 6.0). s3 is in both, and with its fault estimate
    taken out its target s4 is quiet: s3 is the second fault, and s1 is judged by the
    rest (confirmed by s2). When s4's alarm is not s3's doing, the alarm is refused."""
    net = network_from_config(
        ["s0", "s1", "s2", "s3", "s4"],
        {"s0": ["s2"], "s1": ["s0"], "s2": ["s1"], "s3": ["s2"], "s4": ["s3"]},
    )
    g = Grade({"s0": 0.5, "s1": 6.0, "s2": 2.0, "s3": 4.0, "s4": 3.0}, {"s2": 0.5})
    asked = []

    def regrade(quiet):
        def regrade_(s2, out):
            asked.append((s2, set(out)))
            return Grade(g.own, {"s4": quiet})

        return regrade_

    assert _judge(net, "s1", ["s2"], g).changed  # without the second fault: refused
    j = _judge(net, "s1", ["s2"], g, regrade=regrade(0.3))
    assert j.changed is None and j.second == "s3" and j.evidence["second"] == "s3"
    assert j.confirmed == ["s2"] and asked == [("s3", {"s1"})]
    # s3's fault estimate explains little of s4's alarm
    assert _judge(net, "s1", ["s2"], g, regrade=regrade(1.7)).changed
    # alarms of residuals that no one sensor links (s3's sees s2, s4's sees s0 here):
    # no second fault is tried
    far = network_from_config(
        ["s0", "s1", "s2", "s3", "s4"],
        {"s0": ["s2"], "s1": ["s0"], "s2": ["s1"], "s3": ["s2"], "s4": ["s0"]},
    )
    asked.clear()
    assert _judge(far, "s1", ["s2"], g, regrade=regrade(0.3)).changed and asked == []


def test_two_simultaneous_offsets_are_not_refused_as_a_whole_change():
    """``sweep_isolation.py --floors 3 --onset 0.6 --second 0.6001``, seed 6: offsets on
    s3 and s1 from 720 s. Law 0 names s1, and the residuals that cannot see it alarm with
    s3's fault (median 2.26 against s1's 8.31): before, "the data changed as a whole" and
    no finding. s3 explains them and its targets confirm it: s1 is reported, s3 noted as
    the second fault (the pipeline's search without s1 finds it)."""
    rate, duration = 100.0, 1200.0
    t, Y, names = simulate_building(3, duration, rate, seed=6, sensors_per_floor=2)
    for k in (3, 1):
        Y[:, k] = inject_fault(Y[:, k], rate, "additive", 720.0, 0.5 * float(np.std(Y[:, k])))
    ds = Dataset(Y, tuple(names), rate, (0, int(0.2 * duration * rate)))
    det, ctx = EquivalentModel(), RunContext()
    res = det.run(det.fit(ds, ctx), ds, ctx)
    assert [(e.channel, e.type) for e in res.events] == [(names[1], FaultType.ADDITIVE)]
    assert res.events[0].evidence["grade"]["second"] == names[3]
    assert not any("changed as a whole" in n for n in res.notes)


def test_a_model_pickled_before_the_chained_calibrations_loads_without_them():
    """A model file saved before the chained calibrations holds four fields: unpickled,
    its edges have none (a target confirms by its own alarm), not an AttributeError
    that ended ``--model`` with an internal error."""
    import pickle

    from analyzer.detectors.equivalent_model import FittedEquivalentModel
    from analyzer.detectors.network import SensorNetwork

    net = SensorNetwork.ring(["s0", "s1", "s2"])
    new = FittedEquivalentModel(net, (), 25, 3, {("s1", "s0"): None})  # type: ignore[dict-item]
    assert pickle.loads(pickle.dumps(new)).chained == {("s1", "s0"): None}
    old = object.__new__(FittedEquivalentModel)
    old.__setstate__((net, (), 25, 3))  # what a four-field pickle hands over
    assert old.chained == {} and old.window == 25 and old.settle == 3

"""The equivalent model and the channels the config names as measured inputs
(``[[group]] inputs``, ``[model] inputs``): known excitation, never a sensor under test.
They stay out of the sensor network (no observer targets them, none of their residuals is
computed) and each relation takes them as regressors, as the ``u`` of Wang & Song's Eq. 8
is known."""

import numpy as np
import pytest

from analyzer.detectors.base import Dataset, RunContext
from analyzer.detectors.equivalent_model import EquivalentModel, measured_inputs
from analyzer.simulate import inject_fault
from analyzer.simulate_mdof import chain_model, simulate_chain
from analyzer.types import FaultType

RATE = 250.0
NAMES = ("s1", "s2", "s3", "s4", "u1", "u2")
TRAIN = (0, int(60 * RATE))
GROUP = {
    "name": "chain",
    "channels": ["s1", "s2", "s3", "s4"],
    "reference": ["s3", "s4"],
    "uncertain": ["s1", "s2"],
    "inputs": ["u1", "u2"],
}


@pytest.fixture(scope="module")
def chain():
    """Li et al.'s chain at 250 Hz, the forces u1, u2 measured as channels; a gain of
    0.5 on s2 from 100 s (the probe's archive)."""
    _, Y, U = simulate_chain(120.0, RATE, model=chain_model(), noise=0.01, seed=3)
    healthy = np.column_stack([Y, U])
    faulty = healthy.copy()
    faulty[:, 1] = inject_fault(healthy[:, 1], RATE, "multiplicative", 100.0, 0.5)
    return Dataset(healthy, NAMES, RATE, TRAIN), Dataset(faulty, NAMES, RATE, TRAIN)


@pytest.mark.parametrize(
    "config",
    [{"group": [GROUP]}, {"model": {"inputs": ["u1", "u2"]}}],
    ids=["group_inputs", "model_inputs"],
)
def test_measured_inputs_are_regressors_not_sensors(chain, config):
    healthy, faulty = chain
    ctx = RunContext(config=config)
    det = EquivalentModel()
    assert det.applicable(healthy, ctx) is None
    fitted = det.fit(healthy, ctx)
    assert fitted.network.sensors == ("s1", "s2", "s3", "s4")
    assert sorted(NAMES[o.target] for o in fitted.observers) == ["s1", "s2", "s3", "s4"]
    for ob in fitted.observers:  # every relation has both forces among its regressors
        assert {4, 5} <= set(ob.relation.assistants)
    res = det.run(fitted, healthy, ctx)
    assert set(res.residuals) == {"s1", "s2", "s3", "s4"}
    assert res.events == []
    assert not [n for n in res.notes if "u1" in n or "u2" in n]
    res = det.run(fitted, faulty, ctx)
    assert [e.channel for e in res.events] == ["s2"], (res.events, res.notes)
    (ev,) = res.events
    assert ev.type is FaultType.MULTIPLICATIVE
    assert ev.onset_s == pytest.approx(100.0, abs=0.5)
    assert ev.magnitude["gain"] == pytest.approx(0.5, abs=0.05)


def test_without_a_config_every_channel_is_a_sensor(chain):
    """Nothing declared: the forces are channels like the others (as before)."""
    healthy, _ = chain
    fitted = EquivalentModel().fit(healthy, RunContext())
    assert fitted.network.sensors == NAMES


def test_a_configured_network_may_use_an_input_as_assistant_only(chain):
    healthy, _ = chain
    ctx = RunContext(config={"group": [GROUP]})
    table = {"s1": ["u1", "s4"], "s2": ["s1"], "s3": ["s2"], "s4": ["s3"]}
    det = EquivalentModel(assistants=table)
    fitted = det.fit(healthy, ctx)
    assert "u1" in fitted.network.sensors and "u2" not in fitted.network.sensors
    assert "u1" not in [NAMES[o.target] for o in fitted.observers]  # a head: no observer
    res = det.run(fitted, healthy, ctx)
    assert "u1" not in res.residuals
    assert not [n for n in res.notes if n.startswith("u1 cannot be diagnosed")]
    # an input as a target sensor is refused, by name
    bad = EquivalentModel(assistants={"u1": ["s1"], "s2": ["s1"], "s3": ["s2"]})
    reason = bad.applicable(healthy, ctx)
    assert reason is not None and "'u1' a target sensor" in reason and "measured input" in reason


def test_too_few_sensors_once_the_inputs_are_left_out():
    ds = Dataset(np.zeros((100, 4)), ("a", "b", "u1", "u2"), 10.0, (0, 50))
    assert EquivalentModel().applicable(ds, RunContext()) is None
    ctx = RunContext(config={"model": {"inputs": ["u1"]}, "group": [{"inputs": ["u2"]}]})
    assert "at least 3 channels" in (EquivalentModel().applicable(ds, ctx) or "")
    assert measured_inputs(ctx.config) == frozenset({"u1", "u2"})

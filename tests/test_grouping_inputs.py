"""A ``[[group]]``'s measured inputs (excitation channels) belong to that group, and are
not sensors under test (analyzer.grouping, analyzer.config, the pipeline's diagnosis)."""

from __future__ import annotations

import numpy as np

from analyzer.config import load_config
from analyzer.detectors.base import DetectorResult, Event
from analyzer.diagnosis.stuck import healthy_stats
from analyzer.grouping import partition
from analyzer.pipeline import _diagnose, measured_inputs
from analyzer.simulate import simulate_building
from analyzer.types import FaultType


def _channels(extra: int = 2):
    """Six building sensors s0..s5 and ``extra`` excitation channels u1, u2..."""
    _, Y, names = simulate_building(3, 30.0, 50.0, seed=2, sensors_per_floor=2)
    rng = np.random.default_rng(0)
    U = rng.standard_normal((Y.shape[0], extra))
    return [*names, *(f"u{k + 1}" for k in range(extra))], np.hstack([Y, U])


def test_a_groups_inputs_are_in_its_group_not_a_group_of_their_own():
    names, values = _channels()
    group = {
        "name": "b",
        "channels": ["s0", "s1", "s2", "s3", "s4", "s5"],
        "reference": ["s0", "s1", "s4", "s5"],
        "uncertain": ["s2", "s3"],
        "inputs": ["u1", "u2"],
    }
    groups, notes = partition(names, values, [group])
    assert groups == [tuple(names)]
    assert notes == []


def test_a_single_input_raises_no_in_no_group_note():
    names, values = _channels(extra=1)
    group = {"name": "b", "channels": names[:6], "inputs": ["u1"]}
    groups, notes = partition(names, values, [group])
    assert groups == [tuple(names)]
    assert not any("in no [[group]]" in n for n in notes), notes


def test_an_empty_channels_list_takes_the_inputs_too(tmp_path):
    cfg = tmp_path / "c.toml"
    cfg.write_text(
        '[[group]]\nreference = ["s0", "s1"]\nuncertain = ["s2"]\ninputs = ["u1", "u2"]\n'
    )
    assert load_config(cfg).groups[0]["channels"] == ["s0", "s1", "s2", "u1", "u2"]


def test_model_inputs_in_no_group_join_the_group_of_the_models_outputs():
    names, values = _channels()
    groups, notes = partition(
        names,
        values,
        [{"name": "a", "channels": ["s0", "s1", "s2"]}, {"name": "b", "channels": ["s3", "s4"]}],
        model={"outputs": ["s3", "s4"], "inputs": ["u1", "u2"]},
    )
    home = next(g for g in groups if "s3" in g)
    assert {"s4", "u1", "u2"} <= set(home)
    assert len(groups) == 2  # the inputs are no group of their own
    assert not any("u1" in n for n in notes), notes


def test_what_a_detector_saw_on_a_measured_input_is_a_note_not_a_finding():
    rate = 10.0
    rng = np.random.default_rng(1)
    values = rng.standard_normal((400, 2))
    chosen = ["s0", "u1"]
    train = (0, 100)
    event = Event("u1", 25.0, None, FaultType.ADDITIVE, {"offset": 2.0}, 0.9, "ar_kalman_bank")
    result = DetectorResult("ar_kalman_bank", ("s0", "u1"), {}, [event], {})
    healthy = healthy_stats(values, chosen, train)
    findings, _ = _diagnose([result], values, chosen, rate, healthy, train, None)
    assert [f.channel for f in findings] == ["u1"]  # a channel like any other
    excitation = measured_inputs({"group": [{"inputs": ["u1"]}], "model": None})
    findings, notes = _diagnose([result], values, chosen, rate, healthy, train, None, excitation)
    assert findings == []
    assert any(
        "u1 is a measured input (excitation) in the config" in n and "from 25.0 s" in n
        for n in notes
    ), notes


def test_measured_inputs_are_the_groups_and_the_models():
    config = {"group": [{"inputs": ["u1"]}], "model": {"inputs": ["u2"], "outputs": ["s0"]}}
    assert measured_inputs(config) == {"u1", "u2"}
    assert measured_inputs({}) == frozenset()

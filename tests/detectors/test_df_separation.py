"""The detection filter's isolation under a load the models were not fitted on
(``benchmarks/sweep_eov.py``'s ``harmonic_eq`` and ``pedestrian_eq``: a machine's sine or
a walking load on 0.3x broadband excitation, the top floor's response at its training
level). Every filter's residual sits near its direction's threshold there; the filter a
hair below the rest (0.74-0.97 of the typical other's) named its sensor, one other filter
over its threshold "confirmed" it, and healthy records got a gain of ~1.03 or an `other`
on one sensor. Now the sensor's filter must stay clearly closer to its direction than
the typical other (:data:`DIRECTION_SEPARATION`) and most other filters must leave
theirs; a sensor's own fault, large or small, is still isolated."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

from analyzer.detectors.base import Dataset, FaultType, RunContext
from analyzer.detectors.detection_filter import (
    DIRECTION_SEPARATION,
    SEPARATION_OTHERS,
    DetectionFilter,
)
from analyzer.simulate import inject_fault, simulate_building

SCRIPT = Path(__file__).resolve().parents[2] / "benchmarks" / "sweep_eov.py"
if "sweep_eov" not in sys.modules:  # (its dataclasses look their module up there)
    _spec = importlib.util.spec_from_file_location("sweep_eov", SCRIPT)
    assert _spec is not None and _spec.loader is not None
    sys.modules["sweep_eov"] = importlib.util.module_from_spec(_spec)
    _spec.loader.exec_module(sys.modules["sweep_eov"])
sweep = sys.modules["sweep_eov"]


RATE = 100.0


def _run(Y: np.ndarray):
    names = tuple(f"s{i}" for i in range(Y.shape[1]))
    data = Dataset(Y, names, RATE, (0, int(0.2 * len(Y))))
    det, ctx = DetectionFilter(), RunContext()
    return det.run(det.fit(data, ctx), data, ctx)


@pytest.mark.parametrize(
    "case, floors, seed",
    [
        ("harmonic_eq", 8, 3),
        ("harmonic_eq", 3, 0),
        ("pedestrian_eq", 3, 0),
        ("pedestrian_eq", 8, 4),
    ],
)
def test_a_load_of_another_colour_names_no_sensor(case, floors, seed):
    """Healthy records whose filter bank named a sensor before (a multiplicative s1 from
    371.9 s on 16 channels; an `other` on s0 on 6 channels; ...): none now, and the
    alarms are an anomaly attributed to no sensor, the filters' statistics said."""
    _, Y, _ = sweep.record(case, floors, seed, 10.0, False)
    res = _run(Y)
    assert res.events == [], [(e.channel, e.type, e.onset_s) for e in res.events]
    assert res.unattributed or any("not reported: most filters" in n for n in res.notes)
    near = [n for n in res.notes if "about as far" in n]
    for note in near:
        assert "the others' typical" in note


@pytest.mark.parametrize("case, floors, seed", [("harmonic_eq", 8, 3), ("pedestrian_eq", 3, 0)])
def test_an_offset_under_that_load_is_still_isolated(case, floors, seed):
    """The sweep's control: the same records with a lasting 2 sd offset on one sensor
    from 5 s after the load changed."""
    _, Y, faulty = sweep.record(case, floors, seed, 10.0, True)
    res = _run(Y)
    assert faulty in {e.channel for e in res.events}
    ev = next(e for e in res.events if e.channel == faulty)
    assert ev.type == FaultType.ADDITIVE
    others = list(ev.evidence["other_filters_violation"].values())
    assert ev.evidence["off_direction_violation"] <= DIRECTION_SEPARATION * np.median(others)


@pytest.mark.parametrize("seed, kind", [(0, "additive"), (6, "additive"), (16, "multiplicative")])
def test_a_small_fault_on_sixteen_channels_is_still_isolated(seed, kind):
    """``sweep_isolation.py --floors 8 --scale 0.3 --minutes 10``'s faults whose
    filters sat at 0.33-0.46 of the typical other's: still the faulty sensor, by the
    filter bank alone."""
    rng = np.random.default_rng(1000 + seed)
    t, Y, _ = simulate_building(8, 600.0, RATE, seed=seed, sensors_per_floor=2)
    k = int(rng.integers(Y.shape[1]))
    size = {"additive": 0.15 * float(np.std(Y[:, k])), "multiplicative": 1.09}[kind]
    Y[:, k] = inject_fault(Y[:, k], RATE, kind, 360.0, size, None)
    res = _run(Y)
    assert f"s{k}" in {e.channel for e in res.events}, (k, res.notes)


@pytest.mark.parametrize("floors, seed", [(2, 0), (2, 1), (4, 0)])
def test_a_drift_on_few_channels_is_still_isolated(floors, seed):
    """A building of ``floors`` floors, one sensor each, a drift of 1 sd per 10 minutes
    from 360 s: the drifting sensor's filter sits at 0.75-0.80 of the typical other's
    there, so the separation rule (needing :data:`SEPARATION_OTHERS` other filters) does
    not apply, and one other filter over its threshold confirms (the review's case: the
    rule on every record lost these, and the bank's drift on the wrong sensor of the
    2-channel record was reported in the filter's place)."""
    rng = np.random.default_rng(1000 + seed)
    _, Y, _ = simulate_building(floors, 600.0, RATE, seed=seed, sensors_per_floor=1)
    k = int(rng.integers(Y.shape[1]))
    Y[:, k] = inject_fault(Y[:, k], RATE, "drift", 360.0, float(np.std(Y[:, k])) / 600.0, None)
    assert Y.shape[1] - 1 < SEPARATION_OTHERS
    res = _run(Y)
    assert [(e.channel, e.type) for e in res.events] == [(f"s{k}", FaultType.DRIFT)]

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

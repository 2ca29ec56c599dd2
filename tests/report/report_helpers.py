"""A small record the report's tests render: a building at 50 Hz whose second sensor
takes an offset of 3 sd at 36 s of 60, fitted on its first 15 s."""

import numpy as np

from analyzer.findings import Analysis
from analyzer.pipeline import RunOptions, analyze
from analyzer.simulate import inject_fault, simulate_building
from analyzer.writers import write_archive

RATE = 50.0


def offset_building(tmp_path_factory, floors: int) -> Analysis:
    """The analysis of ``floors`` floors with the offset on ``s1``."""
    t, y, names = simulate_building(floors, 60.0, RATE, seed=1)
    y[:, 1] = inject_fault(y[:, 1], RATE, "additive", 36.0, 3.0 * float(np.std(y[:, 1])))
    path = tmp_path_factory.mktemp("b") / "b.csv"
    write_archive(
        path, "csv", np.round(t * 1e9).astype(np.int64), dict(zip(names, y.T, strict=True))
    )
    return analyze([path], RunOptions(train="0:15"))

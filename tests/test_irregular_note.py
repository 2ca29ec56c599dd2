"""Channels sampled at irregular times are analyzed (the store aligns them at their mean
rate) and the run says how: a CSV of six channels stamped together at Poisson times was
half NaN after alignment and refused (exit 2, blaming the training window)."""

from __future__ import annotations

import numpy as np

from analyzer.inspect import inspect_archive, render_table
from analyzer.options import RunOptions
from analyzer.pipeline import analyze
from analyzer.simulate import simulate_building


def test_poisson_timestamps_are_analyzed_and_noted(tmp_path):
    t, Y, names = simulate_building(3, 90.0, 1000.0, seed=12, sensors_per_floor=2)
    rng = np.random.default_rng(12)
    stamps = np.cumsum(rng.exponential(0.01, 8000))
    stamps = stamps[stamps < 89.0]
    rows = np.round(stamps * 1000).astype(int)
    V = Y[rows].copy()
    sd = Y[:20_000, 3].std()
    V[stamps >= 60.0, 3] += 2 * sd
    lines = ["time," + ",".join(names)]
    for s, row in zip(stamps, V, strict=True):
        lines.append(f"{s:.6f}," + ",".join(f"{v:.9g}" for v in row))
    path = tmp_path / "poisson.csv"
    path.write_text("\n".join(lines) + "\n")
    analysis = analyze([path], RunOptions(jobs=1))
    assert [(f.channel, f.type.value) for f in analysis.findings] == [("s3", "additive")]
    assert abs(analysis.findings[0].onset_s - 60.0) < 0.5
    (note,) = [n for n in analysis.notes if "sampled at irregular times" in n]
    assert note.startswith(", ".join(names) + ": sampled at irregular times")
    assert 90.0 < analysis.rate_hz < 110.0  # the mean rate, not the median step's (~144 Hz)


def test_inspect_marks_irregular_channels_only(tmp_path):
    rng = np.random.default_rng(3)
    for name, times in (
        ("poisson", np.cumsum(rng.exponential(0.01, 3000))),
        ("regular", np.arange(3000) * 0.01),
    ):
        rows = [
            f"{t:.6f},{a:.6f},{b:.6f}"
            for t, (a, b) in zip(times, rng.standard_normal((3000, 2)), strict=True)
        ]
        (tmp_path / f"{name}.csv").write_text("time,a,b\n" + "\n".join(rows) + "\n")
    doc = inspect_archive([tmp_path / "poisson.csv"])
    assert [c.get("irregular") for c in doc["channels"]] == [True, True]
    assert "* sampled at irregular times" in render_table(doc)
    doc = inspect_archive([tmp_path / "regular.csv"])
    assert all("irregular" not in c for c in doc["channels"])
    assert "sampled at irregular times" not in render_table(doc)

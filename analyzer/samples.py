"""The bundled samples: Chang et al. (2017)'s five-story building (f1 = 1.01 Hz, 2 %
damping, 200 Hz, ~20 dB SNR, 60 s) with one fault injected on the fifth floor at 16 s,
written in every input format with the real writers. ``samples/truth.json`` records what
was injected, so anyone can check the analyzer's verdict against it.

Regenerate with ``python samples/make_samples.py`` (deterministic: fixed seeds).
"""

from __future__ import annotations

import gzip
import json
import shutil
from pathlib import Path
from typing import Any

import numpy as np

from analyzer.simulate import inject_fault, simulate_building
from analyzer.types import Format
from analyzer.writers import write_archive

START_ISO = "2026-01-01T00:00:00Z"
RATE = 200.0
ONSET_S = 16.0

SAMPLES: list[dict[str, Any]] = [
    # one std_msgs/Float64 topic per accelerometer, zstd chunks
    {
        "file": "building_additive.mcap",
        "format": Format.MCAP,
        "kind": "additive",
        "seed": 0,
        "layout": "float64",
        "compression": "zstd",
    },
    {
        "file": "building_multiplicative.csv.gz",
        "format": Format.CSV,
        "kind": "multiplicative",
        "seed": 1,
        "layout": "float64",
        "compression": None,
    },
    # one Float64MultiArray per tick, lz4 chunks
    {
        "file": "building_drift.bag",
        "format": Format.ROS1BAG,
        "kind": "drift",
        "seed": 2,
        "layout": "multiarray",
        "compression": "lz4",
    },
    {
        "file": "building_healthy_ros2",
        "format": Format.ROS2BAG,
        "kind": None,
        "seed": 3,
        "layout": "multiarray",
        "compression": None,
    },
]


def fault_size(kind: str, y: np.ndarray) -> float:
    """The paper's sizes: offset 80 % of the maximum, gain 1.5, drift 2.5e-3 per sample."""
    return {
        "additive": 0.8 * float(np.max(np.abs(y))),
        "multiplicative": 1.5,
        "drift": 2.5e-3 * RATE,
    }[kind]


def make_samples(out: Path) -> list[dict[str, Any]]:
    out.mkdir(parents=True, exist_ok=True)
    truth = []
    for spec in SAMPLES:
        t, Y, names = simulate_building(
            n_floors=5, duration_s=60.0, rate_hz=RATE, seed=spec["seed"]
        )
        entry: dict[str, Any] = {"file": spec["file"], "format": str(spec["format"]), "faults": []}
        if spec["kind"]:
            size = fault_size(spec["kind"], Y[:, 4])
            Y[:, 4] = inject_fault(Y[:, 4], RATE, spec["kind"], ONSET_S, size)
            key = {"additive": "offset", "multiplicative": "gain", "drift": "rate_per_s"}[
                spec["kind"]
            ]
            entry["faults"].append(
                {"sensor": "s4", "type": spec["kind"], "onset_s": ONSET_S, key: round(size, 6)}
            )
        data = {n: Y[:, j] for j, n in enumerate(names)}
        t_ns = np.round(t * 1e9).astype(np.int64)
        path = out / spec["file"]
        if path.is_dir():
            shutil.rmtree(path)
        elif path.exists():
            path.unlink()
        target = path.with_suffix("") if path.suffix == ".gz" else path
        channels = write_archive(
            target,
            spec["format"],
            t_ns,
            data,
            layout=spec["layout"],
            compression=spec["compression"],
            start_iso=START_ISO,
        )
        if target != path:
            with target.open("rb") as src, gzip.GzipFile(path, "wb", mtime=0) as dst:
                shutil.copyfileobj(src, dst)
            target.unlink()
        entry["channels"] = {k: v for k, v in channels.items()}
        truth.append(entry)
    (out / "truth.json").write_text(json.dumps(truth, indent=2) + "\n", encoding="utf-8")
    return truth
